/* Traces the accel bench's own rays (written by `ACCEL_DUMP=DIR cargo bench -p
 * coatlab-core --bench accel`) with Intel Embree 4 from the `embreex` wheel, so that
 * our BVH can be compared with the state of the art on the same machine, the same
 * triangles and the same rays. See benches/embree/README.md.
 *
 * Usage: embree_rays FILE.bin [low|medium|high] [robust|fast] [threads] [MODES]
 *
 * MODES is a comma-separated list of `single` (rtcIntersect1, one ray at a time:
 * Embree's single-ray kernels, meant for incoherent rays), `packet8` (rtcIntersect8:
 * 8 consecutive rays a call) and `packet16` (rtcIntersect16, only where this Embree
 * build has native 16-wide kernels, i.e. the CPU has AVX-512); default: every
 * available one. For each mode it prints the build time and M rays/s (wall clock,
 * best of 5) for the incoherent rays and the image-order bounces, on `threads`
 * threads taking chunks of 4096 rays from a shared counter, as the Rust bench's rayon
 * does.
 *
 * The declarations are Embree 4.4.0's own headers (include/embree4/, see
 * include/SHA256SUMS); the library's version is checked against them at start-up,
 * and a first, untimed pass through every mode traces each ray with a guard of 64
 * bytes after its RTCRayHit/RTCRayHit8/RTCRayHit16, and fails the run if Embree wrote
 * into it (a layout the headers do not describe). That pass also compares each
 * incoherent ray's hit with ours (FILE.hits beside FILE.bin, when present) and with
 * the single-ray mode's, and lists the rays on which they disagree.
 *
 * EMBREE_ONCE=incoherent|bounce instead builds the scene once and traces the first
 * EMBREE_RAYS (default 65536) rays of that set once, in the first mode of MODES, on
 * one thread, and prints the hit count: for counting instructions a ray under
 * callgrind (--toggle-collect=rtcIntersect1, or rtcIntersect8), as the Rust
 * bench's ACCEL_ONCE does for ours. */
#define _GNU_SOURCE
#include <embree4/rtcore.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <xmmintrin.h>
#include <pmmintrin.h>

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

enum Mode { SINGLE, PACKET8, PACKET16, MODES };
static const char *mode_names[MODES] = {"single", "packet8", "packet16"};
static const char *mode_calls[MODES] = {"rtcIntersect1", "rtcIntersect8", "rtcIntersect16"};

/* Bytes after each ray structure that Embree must leave alone. */
enum { GUARD = 64, GUARD_BYTE = 0xa5 };

struct Guarded1 {
  struct RTCRayHit rh;
  unsigned char guard[GUARD];
};
struct Guarded8 {
  struct RTCRayHit8 rh;
  unsigned char guard[GUARD];
};
struct Guarded16 {
  struct RTCRayHit16 rh;
  unsigned char guard[GUARD];
};

/* A ray's result: the triangle hit (RTC_INVALID_GEOMETRY_ID for a miss) and t. */
struct Result {
  unsigned prim;
  float t;
};

struct Work {
  RTCScene scene;
  enum Mode mode;
  const float *rays; /* origin, direction: 6 floats a ray */
  size_t count;
  atomic_size_t next;
  atomic_size_t hits;
  /* The checking pass: per-ray results, and the guards are checked. */
  struct Result *results;
  atomic_int guard_broken;
};

enum { CHUNK = 4096 };

static int guard_intact(const unsigned char *guard) {
  for (int i = 0; i < GUARD; i++)
    if (guard[i] != GUARD_BYTE) return 0;
  return 1;
}

static void trace_single(struct Work *w, size_t start, size_t end, size_t *hits) {
  struct Guarded1 g;
  for (size_t i = start; i < end; i++) {
    const float *r = w->rays + 6 * i;
    memset(&g.rh, 0, sizeof g.rh);
    if (w->results) memset(g.guard, GUARD_BYTE, GUARD);
    struct RTCRayHit *rh = &g.rh;
    rh->ray.org_x = r[0], rh->ray.org_y = r[1], rh->ray.org_z = r[2];
    rh->ray.dir_x = r[3], rh->ray.dir_y = r[4], rh->ray.dir_z = r[5];
    rh->ray.tnear = 0.0f;
    rh->ray.tfar = INFINITY;
    rh->ray.mask = (unsigned)-1;
    rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(w->scene, rh, NULL);
    int hit = rh->hit.geomID != RTC_INVALID_GEOMETRY_ID;
    *hits += hit;
    if (w->results) {
      w->results[i] = (struct Result){hit ? rh->hit.primID : RTC_INVALID_GEOMETRY_ID,
                                      hit ? rh->ray.tfar : INFINITY};
      if (!guard_intact(g.guard)) atomic_store(&w->guard_broken, 1);
    }
  }
}

/* rtcIntersect8 and rtcIntersect16 on `W` consecutive rays a call; lanes past `end`
 * are invalid. */
#define TRACE_PACKET(W)                                                               \
  static void trace_packet##W(struct Work *w, size_t start, size_t end, size_t *hits) { \
    struct Guarded##W g;                                                              \
    for (size_t base = start; base < end; base += W) {                                \
      int valid[W];                                                                   \
      memset(&g.rh, 0, sizeof g.rh);                                                  \
      if (w->results) memset(g.guard, GUARD_BYTE, GUARD);                             \
      struct RTCRayHit##W *rh = &g.rh;                                                       \
      for (int k = 0; k < W; k++) {                                                   \
        size_t i = base + k;                                                          \
        valid[k] = i < end ? -1 : 0;                                                  \
        const float *r = w->rays + 6 * (i < end ? i : start);                         \
        rh->ray.org_x[k] = r[0], rh->ray.org_y[k] = r[1], rh->ray.org_z[k] = r[2];    \
        rh->ray.dir_x[k] = r[3], rh->ray.dir_y[k] = r[4], rh->ray.dir_z[k] = r[5];    \
        rh->ray.tnear[k] = 0.0f;                                                      \
        rh->ray.tfar[k] = INFINITY;                                                   \
        rh->ray.mask[k] = (unsigned)-1;                                               \
        rh->hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;                                  \
        rh->hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;                               \
      }                                                                               \
      rtcIntersect##W(valid, w->scene, rh, NULL);                                     \
      for (int k = 0; k < W && base + k < end; k++) {                                 \
        int hit = rh->hit.geomID[k] != RTC_INVALID_GEOMETRY_ID;                       \
        *hits += hit;                                                                 \
        if (w->results)                                                               \
          w->results[base + k] = (struct Result){                                     \
              hit ? rh->hit.primID[k] : RTC_INVALID_GEOMETRY_ID,                      \
              hit ? rh->ray.tfar[k] : INFINITY};                                      \
      }                                                                               \
      if (w->results && !guard_intact(g.guard)) atomic_store(&w->guard_broken, 1);    \
    }                                                                                 \
  }
TRACE_PACKET(8)
TRACE_PACKET(16)

static void *trace(void *arg) {
  struct Work *w = arg;
  /* As Embree asks of every thread that calls it. */
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  size_t hits = 0;
  for (;;) {
    size_t start = atomic_fetch_add(&w->next, CHUNK);
    if (start >= w->count) break;
    size_t end = start + CHUNK < w->count ? start + CHUNK : w->count;
    switch (w->mode) {
      case SINGLE: trace_single(w, start, end, &hits); break;
      case PACKET8: trace_packet8(w, start, end, &hits); break;
      default: trace_packet16(w, start, end, &hits); break;
    }
  }
  atomic_fetch_add(&w->hits, hits);
  return NULL;
}

/* Traces `count` rays once on `threads` threads; returns the wall-clock seconds. */
static double run_once(RTCScene scene, enum Mode mode, const float *rays, size_t count,
                       int threads, struct Result *results, size_t *hits, int *guard_broken) {
  struct Work w = {scene, mode, rays, count, 0, 0, results, 0};
  pthread_t tid[64];
  double t0 = now();
  for (int t = 0; t < threads; t++) pthread_create(&tid[t], NULL, trace, &w);
  for (int t = 0; t < threads; t++) pthread_join(tid[t], NULL);
  double seconds = now() - t0;
  *hits = w.hits;
  if (guard_broken) *guard_broken = w.guard_broken;
  return seconds;
}

/* Best of 5 wall-clock rates, M rays/s; the hit count in *hits. */
static double rate(RTCScene scene, enum Mode mode, const float *rays, size_t count,
                   int threads, size_t *hits) {
  double best = 0.0;
  for (int run = 0; run < 5; run++) {
    double r = count / run_once(scene, mode, rays, count, threads, NULL, hits, NULL) / 1e6;
    if (r > best) best = r;
  }
  return best;
}

/* The checking pass of one mode over one ray set: per-ray results into `results`;
 * exits if a guard was written. */
static void check_pass(RTCScene scene, enum Mode mode, const float *rays, size_t count,
                       int threads, struct Result *results, const char *what) {
  size_t hits;
  int broken;
  run_once(scene, mode, rays, count, threads, results, &hits, &broken);
  if (broken) {
    size_t size = mode == SINGLE ? sizeof(struct RTCRayHit)
                  : mode == PACKET8 ? sizeof(struct RTCRayHit8)
                                    : sizeof(struct RTCRayHit16);
    fprintf(stderr,
            "%s (%s rays): Embree wrote past the %zu bytes of the ray structure that "
            "include/embree4 declares: the headers do not describe this library\n",
            mode_calls[mode], what, size);
    exit(1);
  }
}

static void print_ray(const char *label, const float *rays, size_t i, struct Result a,
                      const char *a_name, struct Result b, const char *b_name) {
  const float *r = rays + 6 * i;
  printf("  %s ray %zu: origin (%.9g, %.9g, %.9g) dir (%.9g, %.9g, %.9g): %s ", label, i,
         r[0], r[1], r[2], r[3], r[4], r[5], a_name);
  if (a.prim == RTC_INVALID_GEOMETRY_ID)
    printf("miss");
  else
    printf("triangle %u at t %.9g", a.prim, a.t);
  printf(", %s ", b_name);
  if (b.prim == RTC_INVALID_GEOMETRY_ID)
    printf("miss\n");
  else
    printf("triangle %u at t %.9g\n", b.prim, b.t);
}

/* Compares two per-ray result lists: rays hit by one and missed by the other, and
 * rays that hit different triangles, are listed (up to 20) and counted. */
static void compare(const char *label, const float *rays, size_t count,
                    const struct Result *a, const char *a_name, const struct Result *b,
                    const char *b_name) {
  size_t only_a = 0, only_b = 0, other = 0, listed = 0;
  for (size_t i = 0; i < count; i++) {
    int ha = a[i].prim != RTC_INVALID_GEOMETRY_ID, hb = b[i].prim != RTC_INVALID_GEOMETRY_ID;
    if (ha == hb && (!ha || a[i].prim == b[i].prim)) continue;
    if (ha && hb)
      other++;
    else
      *(ha ? &only_a : &only_b) += 1;
    if (listed++ < 20) print_ray(label, rays, i, a[i], a_name, b[i], b_name);
  }
  printf("%s: %zu rays hit by %s only, %zu by %s only, %zu hit different triangles\n", label,
         only_a, a_name, only_b, b_name, other);
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr,
            "usage: %s FILE.bin [low|medium|high] [robust|fast] [threads] "
            "[single,packet8,packet16]\n",
            argv[0]);
    return 2;
  }
  const char *quality_name = argc > 2 ? argv[2] : "medium";
  enum RTCBuildQuality quality = !strcmp(quality_name, "low")    ? RTC_BUILD_QUALITY_LOW
                                 : !strcmp(quality_name, "high") ? RTC_BUILD_QUALITY_HIGH
                                                                 : RTC_BUILD_QUALITY_MEDIUM;
  int robust = argc > 3 && !strcmp(argv[3], "robust");
  int threads = argc > 4 ? atoi(argv[4]) : 2;
  if (threads < 1 || threads > 64) threads = 2;
  const char *modes_arg = argc > 5 ? argv[5] : "single,packet8,packet16";

  FILE *f = fopen(argv[1], "rb");
  if (!f) {
    perror(argv[1]);
    return 1;
  }
  uint32_t head[5];
  if (fread(head, 4, 5, f) != 5) {
    fprintf(stderr, "%s: truncated header\n", argv[1]);
    return 1;
  }
  size_t nv = head[0], nt = head[1], nr = head[2], nb = head[3];
  float *vertices = malloc(12 * nv + 16);
  uint32_t *triangles = malloc(12 * nt);
  float *rays = malloc(24 * (nr + nb));
  if (fread(vertices, 12, nv, f) != nv || fread(triangles, 12, nt, f) != nt ||
      fread(rays, 24, nr + nb, f) != nr + nb) {
    fprintf(stderr, "%s: truncated data\n", argv[1]);
    return 1;
  }
  fclose(f);
  /* Our per-ray hits, FILE.hits (see the accel bench's `dump`), when present. */
  struct Result *ours = NULL;
  {
    char path[4096];
    size_t n = strlen(argv[1]);
    if (n > 4 && !strcmp(argv[1] + n - 4, ".bin") && n < sizeof path) {
      snprintf(path, sizeof path, "%.*s.hits", (int)(n - 4), argv[1]);
      FILE *h = fopen(path, "rb");
      if (h) {
        ours = malloc(sizeof *ours * nr);
        for (size_t i = 0; i < nr; i++) {
          uint32_t record[2];
          if (fread(record, 4, 2, h) != 2) {
            fprintf(stderr, "%s: truncated at ray %zu\n", path, i);
            return 1;
          }
          ours[i].prim = record[0];
          memcpy(&ours[i].t, &record[1], 4);
        }
        fclose(h);
      }
    }
  }

  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  char config[128];
  snprintf(config, sizeof config, "threads=%d%s%s%s", threads,
           getenv("EMBREE_VERBOSE") ? ",verbose=2" : "", getenv("EMBREE_ISA") ? ",max_isa=" : "",
           getenv("EMBREE_ISA") ? getenv("EMBREE_ISA") : "");
  RTCDevice device = rtcNewDevice(config);
  if (!device) {
    fprintf(stderr, "rtcNewDevice failed: %d\n", rtcGetDeviceError(NULL));
    return 1;
  }
  ssize_t version = rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION);
  if (version != RTC_VERSION) {
    fprintf(stderr, "the library is Embree %zd, the headers (include/embree4) are %d\n", version,
            RTC_VERSION);
    return 1;
  }
  int available[MODES] = {
      1, (int)rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED),
      (int)rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED)};
  int wanted[MODES] = {0};
  for (int m = 0; m < MODES; m++) {
    const char *p = strstr(modes_arg, mode_names[m]);
    size_t len = strlen(mode_names[m]);
    wanted[m] = p && (p[len] == ',' || p[len] == '\0') && available[m];
    if (p && !available[m])
      printf("%s: skipped, this Embree build on this CPU has no native %s kernels\n",
             mode_calls[m], mode_names[m] + 6);
  }

  const char *once = getenv("EMBREE_ONCE");
  if (once && strcmp(once, "incoherent") && strcmp(once, "bounce")) {
    fprintf(stderr, "EMBREE_ONCE=%s: expected incoherent or bounce\n", once);
    return 2;
  }
  double best_build = 1e9;
  RTCScene scene = NULL;
  for (int run = 0; run < (once ? 1 : 5); run++) {
    if (scene) rtcReleaseScene(scene);
    double t0 = now();
    scene = rtcNewScene(device);
    if (robust) rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(scene, quality);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, quality);
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, nv);
    uint32_t *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, nt);
    memcpy(vb, vertices, 12 * nv);
    memcpy(ib, triangles, 12 * nt);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    double t = now() - t0;
    if (t < best_build) best_build = t;
  }
  int error = rtcGetDeviceError(device);
  if (error) {
    fprintf(stderr, "Embree error %d\n", error);
    return 1;
  }

  if (once) {
    int bounce = !strcmp(once, "bounce");
    size_t available_rays = bounce ? nb : nr;
    const char *count_arg = getenv("EMBREE_RAYS");
    size_t count = count_arg ? strtoull(count_arg, NULL, 10) : 65536;
    if (count == 0 || count > available_rays) {
      fprintf(stderr, "EMBREE_RAYS=%s: expected 1 to %zu\n", count_arg ? count_arg : "",
              available_rays);
      return 2;
    }
    int m = 0;
    while (m < MODES && !wanted[m]) m++;
    if (m == MODES) {
      fprintf(stderr, "%s: no available mode in '%s'\n", argv[1], modes_arg);
      return 2;
    }
    size_t hits;
    run_once(scene, m, bounce ? rays + 6 * nr : rays, count, 1, NULL, &hits, NULL);
    printf("%s | embree %s%s %s | %s rays: %zu of %zu hit\n", argv[1], quality_name,
           robust ? " robust" : "", mode_names[m], once, hits, count);
    return 0;
  }

  /* The checking pass: every mode, both ray sets, guards checked; the incoherent
   * rays' hits compared. */
  struct Result *single = malloc(sizeof *single * nr);
  struct Result *scratch = malloc(sizeof *scratch * (nr > nb ? nr : nb));
  for (int m = 0; m < MODES; m++) {
    if (!wanted[m] && m != SINGLE) continue;
    check_pass(scene, m, rays + 6 * nr, nb, threads, scratch, "image-order bounce");
    check_pass(scene, m, rays, nr, threads, m == SINGLE ? single : scratch, "incoherent");
    if (m != SINGLE) {
      char label[128];
      snprintf(label, sizeof label, "%s: %s vs rtcIntersect1, incoherent rays", argv[1],
               mode_calls[m]);
      compare(label, rays, nr, scratch, mode_calls[m], single, "rtcIntersect1");
    }
  }
  if (ours) {
    char label[128];
    snprintf(label, sizeof label, "%s: embree %s%s vs coatlab, incoherent rays", argv[1],
             quality_name, robust ? " robust" : "");
    compare(label, rays, nr, single, "embree", ours, "coatlab");
  }

  for (int m = 0; m < MODES; m++) {
    if (!wanted[m]) continue;
    size_t hits, bounce_hits;
    double incoherent = rate(scene, m, rays, nr, threads, &hits);
    double bounce = rate(scene, m, rays + 6 * nr, nb, threads, &bounce_hits);
    printf("%s | %zu triangles | embree %s%s %s | %d threads | build %.1f ms | incoherent "
           "%.2f M/s (%zu of %zu hit; coatlab %u) | image-order bounce %.2f M/s (%zu of %zu "
           "hit)\n",
           argv[1], nt, quality_name, robust ? " robust" : "", mode_names[m], threads,
           1e3 * best_build, incoherent, hits, nr, head[4], bounce, bounce_hits, nb);
  }
  return 0;
}
