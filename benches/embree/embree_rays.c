/* Traces the accel bench's own rays (written by `ACCEL_DUMP=DIR cargo bench -p
 * coatlab-core --bench accel`) with Intel Embree 4 from the `embreex` wheel, so that
 * our BVH can be compared with the state of the art on the same machine, the same
 * triangles and the same rays. See benches/embree/README.md.
 *
 * Usage: embree_rays FILE.bin [low|medium|high] [robust|fast] [threads]
 *
 * Prints the build time and M rays/s (wall clock, best of 5) for the incoherent
 * rays and the image-order bounces, each through rtcIntersect1 one ray at a time
 * (Embree's single-ray kernels, meant for incoherent rays), on `threads` threads
 * taking chunks of 4096 rays from a shared counter, as the Rust bench's rayon does.
 *
 * The Embree 4 declarations are written out here (the wheel ships the library
 * only); their values are those of embree4/rtcore_common.h. */
#define _GNU_SOURCE
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <xmmintrin.h>
#include <pmmintrin.h>

typedef void *RTCDevice;
typedef void *RTCScene;
typedef void *RTCGeometry;
enum { RTC_GEOMETRY_TYPE_TRIANGLE = 0 };
enum { RTC_BUFFER_TYPE_INDEX = 0, RTC_BUFFER_TYPE_VERTEX = 1 };
enum { RTC_FORMAT_UINT3 = 0x5003, RTC_FORMAT_FLOAT3 = 0x9003 };
enum { RTC_SCENE_FLAG_ROBUST = 1 << 2 };
#define RTC_INVALID_GEOMETRY_ID ((unsigned)-1)

struct __attribute__((aligned(16))) RTCRay {
  float org_x, org_y, org_z, tnear;
  float dir_x, dir_y, dir_z, time;
  float tfar;
  unsigned mask, id, flags;
};
struct __attribute__((aligned(16))) RTCHit {
  float Ng_x, Ng_y, Ng_z, u, v;
  unsigned primID, geomID, instID[1];
};
struct __attribute__((aligned(16))) RTCRayHit {
  struct RTCRay ray;
  struct RTCHit hit;
};

RTCDevice rtcNewDevice(const char *config);
int rtcGetDeviceError(RTCDevice device);
RTCScene rtcNewScene(RTCDevice device);
void rtcSetSceneFlags(RTCScene scene, int flags);
void rtcSetSceneBuildQuality(RTCScene scene, int quality);
RTCGeometry rtcNewGeometry(RTCDevice device, int type);
void *rtcSetNewGeometryBuffer(RTCGeometry geometry, int type, unsigned slot, int format,
                              size_t byteStride, size_t itemCount);
void rtcSetGeometryBuildQuality(RTCGeometry geometry, int quality);
void rtcCommitGeometry(RTCGeometry geometry);
unsigned rtcAttachGeometry(RTCScene scene, RTCGeometry geometry);
void rtcReleaseGeometry(RTCGeometry geometry);
void rtcCommitScene(RTCScene scene);
void rtcReleaseScene(RTCScene scene);
void rtcIntersect1(RTCScene scene, struct RTCRayHit *rayhit, void *args);

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

struct Work {
  RTCScene scene;
  const float *rays; /* origin, direction: 6 floats a ray */
  size_t count;
  atomic_size_t next;
  atomic_size_t hits;
};

enum { CHUNK = 4096 };

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
    for (size_t i = start; i < end; i++) {
      const float *r = w->rays + 6 * i;
      struct RTCRayHit rh;
      memset(&rh, 0, sizeof rh);
      rh.ray.org_x = r[0], rh.ray.org_y = r[1], rh.ray.org_z = r[2];
      rh.ray.dir_x = r[3], rh.ray.dir_y = r[4], rh.ray.dir_z = r[5];
      rh.ray.tnear = 0.0f;
      rh.ray.tfar = __builtin_inff();
      rh.ray.mask = (unsigned)-1;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(w->scene, &rh, NULL);
      hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
  }
  atomic_fetch_add(&w->hits, hits);
  return NULL;
}

/* Best of `runs` wall-clock rates, M rays/s; the hit count in *hits. */
static double rate(RTCScene scene, const float *rays, size_t count, int threads,
                   size_t *hits) {
  double best = 0.0;
  for (int run = 0; run < (getenv("EMBREE_ONCE") ? 1 : 5); run++) {
    struct Work w = {scene, rays, getenv("EMBREE_N") ? (size_t)atol(getenv("EMBREE_N")) : count, 0, 0};
    pthread_t tid[64];
    double t0 = now();
    for (int t = 0; t < threads; t++) pthread_create(&tid[t], NULL, trace, &w);
    for (int t = 0; t < threads; t++) pthread_join(tid[t], NULL);
    double r = count / (now() - t0) / 1e6;
    if (r > best) best = r;
    *hits = w.hits;
  }
  return best;
}

int main(int argc, char **argv) {
  if (argc < 2) {
    fprintf(stderr, "usage: %s FILE.bin [low|medium|high] [robust|fast] [threads]\n", argv[0]);
    return 2;
  }
  const char *quality_name = argc > 2 ? argv[2] : "medium";
  int quality = !strcmp(quality_name, "low") ? 0 : !strcmp(quality_name, "high") ? 2 : 1;
  int robust = argc > 3 && !strcmp(argv[3], "robust");
  int threads = argc > 4 ? atoi(argv[4]) : 2;
  if (threads < 1 || threads > 64) threads = 2;

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

  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  char config[64];
  snprintf(config, sizeof config, "threads=%d%s", threads, getenv("EMBREE_VERBOSE") ? ",verbose=2" : "");
  RTCDevice device = rtcNewDevice(config);
  if (!device) {
    fprintf(stderr, "rtcNewDevice failed: %d\n", rtcGetDeviceError(NULL));
    return 1;
  }
  double best_build = 1e9;
  RTCScene scene = NULL;
  for (int run = 0; run < 5; run++) {
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
  size_t hits, bounce_hits;
  double incoherent = rate(scene, rays, nr, threads, &hits);
  double bounce = rate(scene, rays + 6 * nr, nb, threads, &bounce_hits);
  printf("%s | %zu triangles | embree %s%s | %d threads | build %.1f ms | incoherent %.2f M/s "
         "(%zu of %zu hit; coatlab %u) | image-order bounce %.2f M/s (%zu of %zu hit)\n",
         argv[1], nt, quality_name, robust ? " robust" : "", threads, 1e3 * best_build, incoherent,
         hits, nr, head[4], bounce, bounce_hits, nb);
  return 0;
}
