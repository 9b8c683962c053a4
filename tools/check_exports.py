#!/usr/bin/env python3
"""Checks `coatlab export` files with readers that share no code with Coatlab.

    python3 tools/check_exports.py [--xsd CxF3_Core.xsd] design.cxf design.txt car.glb

- CxF3 (.cxf): with `--xsd vendor/cxf3/CxF3_Core.xsd`, a validation against
  X-Rite's official CxF3 core schema 3.0.018 (vendored unmodified with its
  licence, vendor/cxf3/README.md) by the `xmlschema` package (pip install
  xmlschema, or Debian's python3-xmlschema); CI runs it on every preset's
  export (.ci/check-cxf).
  Always, Python's ElementTree asserting what Coatlab's exports hold beyond what
  the schema requires: root cc:CxF with FileInformation (Creator, an xs:dateTime
  CreationDate), Resources (ObjectCollection, ColorSpecificationCollection) and an
  optional CustomResources holding only elements of other namespaces; every
  Object with ObjectType, Name and a unique Id; every colour value naming a
  ColorSpecification that exists; every specification with TristimulusSpec
  (Illuminant, Observer, Method) and MeasurementSpec (MeasurementType, one
  GeometryChoice, a WavelengthRange); spectra within the CIE range; every gloss
  reading's Method naming its angle (`specular gloss 60°`).
- CGATS.17 (.txt): a plain tokeniser of the ANSI CGATS.17 layout: keyword
  header, NUMBER_OF_FIELDS equal to the fields declared, NUMBER_OF_SETS equal to
  the rows, every row with that many values.
- glTF (.glb): pygltflib (pip install pygltflib) loads the file; the asset is
  version 2.0, every accessor lies inside its buffer view and its view inside
  the buffer, every index is below its vertex count, the paint material has
  KHR_materials_clearcoat and KHR_materials_ior (both listed in extensionsUsed)
  and its extras carry the ΔE00 per geometry.

Prints one line per file and exits non-zero on the first failure.
"""

import json
import re
import struct
import sys
import xml.etree.ElementTree as ET

CC = "{http://colorexchangeformat.com/CxF3-core}"
GEOMETRIES = {"SingleAngle", "SphereGeometry", "MultiAngle", "BRDFAngle"}


def local(tag):
    return tag.split("}", 1)[-1]


SCHEMA = None


def check_cxf(path):
    if SCHEMA is not None:
        SCHEMA.validate(path)
    root = ET.parse(path).getroot()
    assert root.tag == CC + "CxF", root.tag
    children = [c.tag for c in root]
    assert children[:2] == [CC + "FileInformation", CC + "Resources"], children
    assert children[2:] in ([], [CC + "CustomResources"]), children
    info = root.find(CC + "FileInformation")
    assert info.findtext(CC + "Creator"), "no Creator"
    date = info.findtext(CC + "CreationDate") or ""
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(Z|[+-]\d\d:\d\d)?", date), date
    resources = root.find(CC + "Resources")
    specs = {}
    for spec in resources.iter(CC + "ColorSpecification"):
        sid = spec.get("Id")
        assert sid and sid not in specs, f"ColorSpecification Id {sid!r}"
        tri = spec.find(CC + "TristimulusSpec")
        for field in ("Illuminant", "Observer", "Method"):
            assert tri is not None and tri.findtext(CC + field), f"{sid}: {field}"
        ms = spec.find(CC + "MeasurementSpec")
        assert ms is not None and ms.findtext(CC + "MeasurementType"), sid
        choice = ms.find(CC + "GeometryChoice")
        kinds = [local(c.tag) for c in choice]
        assert len(kinds) == 1 and kinds[0] in GEOMETRIES, f"{sid}: {kinds}"
        wr = ms.find(CC + "WavelengthRange")
        start, step = float(wr.get("StartWL")), float(wr.get("Increment"))
        assert 360 <= start <= 830 and step > 0, (start, step)
        specs[sid] = (start, step)
    ids = set()
    values = 0
    for obj in resources.iter(CC + "Object"):
        for attr in ("ObjectType", "Name", "Id"):
            assert obj.get(attr), f"Object lacks {attr}"
        assert obj.get("Id") not in ids, obj.get("Id")
        ids.add(obj.get("Id"))
        for value in obj.find(CC + "ColorValues"):
            name = local(value.tag)
            if name in ("ReflectanceSpectrum", "ColorCIELab"):
                ref = value.get("ColorSpecification")
                assert ref in specs, f"{name} names {ref!r}"
            if name == "ReflectanceSpectrum":
                numbers = [float(v) for v in value.text.split()]
                start, step = specs[value.get("ColorSpecification")]
                assert start + step * (len(numbers) - 1) <= 830
                assert all(-0.05 <= v <= 1.5 for v in numbers)
                values += 1
            elif name == "ColorCIELab":
                for ch in ("L", "A", "B"):
                    float(value.findtext(CC + ch))
        for gloss in obj.iter(CC + "Gloss"):
            method = gloss.get("Method") or ""
            assert re.fullmatch(r"specular gloss \d+(\.\d+)?°", method), f"gloss Method {method!r}"
            float(gloss.text)
    custom = root.find(CC + "CustomResources")
    if custom is not None:
        for c in custom:
            assert not c.tag.startswith(CC), f"CustomResources holds a core element {c.tag}"
    assert values > 0, "no spectra"
    valid = "valid against the CxF3 schema, " if SCHEMA is not None else ""
    return f"{valid}{len(ids)} object(s), {values} spectra, {len(specs)} specifications"


def check_cgats(path):
    lines = [l.strip() for l in open(path, encoding="utf-8").read().splitlines()]
    fields_declared = int(next(l.split()[1] for l in lines if l.startswith("NUMBER_OF_FIELDS")))
    sets = int(next(l.split()[1] for l in lines if l.startswith("NUMBER_OF_SETS")))
    fields = lines[lines.index("BEGIN_DATA_FORMAT") + 1 : lines.index("END_DATA_FORMAT")]
    names = " ".join(fields).split()
    assert len(names) == fields_declared, (len(names), fields_declared)
    rows = lines[lines.index("BEGIN_DATA") + 1 : lines.index("END_DATA")]
    assert len(rows) == sets, (len(rows), sets)
    for row in rows:
        tokens = re.findall(r'"[^"]*"|\S+', row)
        assert len(tokens) == fields_declared, row[:60]
        for name, token in zip(names, tokens):
            if name.startswith("SPECTRAL_NM") or name.startswith("GLOSS_"):
                float(token)
    return f"{fields_declared} fields, {sets} rows"


def check_glb(path):
    from pygltflib import GLTF2

    gltf = GLTF2().load(path)
    assert gltf.asset.version == "2.0", gltf.asset.version
    blob = gltf.binary_blob()
    sizes = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
    width = {5121: 1, 5123: 2, 5125: 4, 5126: 4}
    for a in gltf.accessors:
        view = gltf.bufferViews[a.bufferView]
        assert view.byteOffset + view.byteLength <= gltf.buffers[view.buffer].byteLength
        assert len(blob) >= gltf.buffers[view.buffer].byteLength
        need = (a.byteOffset or 0) + a.count * sizes[a.type] * width[a.componentType]
        assert need <= view.byteLength, "accessor beyond its view"
    for mesh in gltf.meshes:
        for p in mesh.primitives:
            vertices = gltf.accessors[p.attributes.POSITION].count
            idx = gltf.accessors[p.indices]
            view = gltf.bufferViews[idx.bufferView]
            data = blob[view.byteOffset : view.byteOffset + idx.count * 4]
            assert max(struct.unpack(f"<{idx.count}I", data)) < vertices
    used = set(gltf.extensionsUsed or [])
    painted = [
        m for m in gltf.materials
        if m.extensions and "KHR_materials_clearcoat" in m.extensions
    ]
    assert painted, "no clear-coat material"
    for m in painted:
        assert {"KHR_materials_clearcoat", "KHR_materials_ior"} <= used, used
        assert m.extensions["KHR_materials_ior"]["ior"] >= 1.0
        extras = m.extras if isinstance(m.extras, dict) else json.loads(m.extras)
        costs = extras["coatlab"]["delta_e00"]
        assert len(costs) == 5, costs
    return f"{len(gltf.meshes[0].primitives)} primitive(s), paint {painted[0].name!r}"


def main(paths):
    global SCHEMA
    if paths[:1] == ["--xsd"]:
        import xmlschema

        SCHEMA = xmlschema.XMLSchema(paths[1])
        paths = paths[2:]
    checks = {"cxf": check_cxf, "glb": check_glb}
    for path in paths:
        check = checks.get(path.rsplit(".", 1)[-1].lower(), check_cgats)
        print(f"{path}: ok ({check(path)})")


if __name__ == "__main__":
    main(sys.argv[1:])
