#!/usr/bin/env python3
"""Writes the measurement-file fixtures of crates/coatlab-core/tests/data/measurements/.

Every spectrum is an analytic curve of this script (no instrument's or anyone
else's data): a red (a logistic edge at 600 nm), a blue (a Gaussian band at
450 nm) and a grey, at 4 decimals; multi-angle readings scale the 45° curve by a
flop factor per aspecular angle. The malformed files are the well-formed ones
with one thing broken, named by the file. Standard library only.

Usage: python3 tools/make_measurement_fixtures.py
"""

import math
import pathlib

OUT = pathlib.Path(__file__).resolve().parent.parent / "crates/coatlab-core/tests/data/measurements"

ANGLES = [-15, 15, 25, 45, 75, 110]
FLOP = {-15: 1.9, 15: 1.6, 25: 1.25, 45: 1.0, 75: 0.82, 110: 0.74}


def red(nm):
    return 0.05 + 0.75 / (1.0 + math.exp(-(nm - 600.0) / 15.0))


def blue(nm):
    return 0.04 + 0.36 * math.exp(-(((nm - 450.0) / 40.0) ** 2))


def grey(nm):
    return 0.42 + 0.0001 * (nm - 550.0)


def values(curve, wavelengths, scale=1.0, factor=1.0):
    return [f"{min(curve(w) * factor, 1.0) * scale:.4f}" for w in wavelengths]


def grid(start, stop, step):
    return list(range(start, stop + 1, step))


def cgats(header_lines, fields, rows, eol="\n", first_line="CGATS.17"):
    lines = [first_line] if first_line else []
    lines += header_lines
    lines.append(f"NUMBER_OF_FIELDS {len(fields)}")
    lines.append("BEGIN_DATA_FORMAT")
    lines.append(" ".join(fields))
    lines.append("END_DATA_FORMAT")
    lines.append(f"NUMBER_OF_SETS {len(rows)}")
    lines.append("BEGIN_DATA")
    lines += [" ".join(r) for r in rows]
    lines.append("END_DATA")
    return eol.join(lines) + eol


HEADER = [
    'ORIGINATOR "tools/make_measurement_fixtures.py (synthetic spectra)"',
    'CREATED "2026-01-01"',
]


def write(name, text):
    (OUT / name).write_text(text, encoding="utf-8", newline="")


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    curves = [("1", "Signal red", red), ("2", "Deep blue", blue), ("3", "Grey", grey)]

    # 1. SPECTRAL_NM_ columns, fractions, 10 nm 380-730, both ids, Lab beside.
    w = grid(380, 730, 10)
    fields = ["SAMPLE_ID", "SAMPLE_NAME"] + [f"SPECTRAL_NM_{x}" for x in w]
    rows = [[i, f'"{n}"'] + values(c, w) for i, n, c in curves]
    write("spectral_fraction_10nm.cgats", cgats(
        HEADER + ['MEASUREMENT_GEOMETRY "d:8 SCI"', 'WEIGHTING_FUNCTION "ILLUMINANT, D65"',
                  'WEIGHTING_FUNCTION "OBSERVER, 10 degree"'], fields, rows))

    # 2. nm columns, percent, 5 nm 400-700, CRLF, no CGATS.17 line, SAMPLE_NAME only.
    w = grid(400, 700, 5)
    fields = ["SAMPLE_NAME"] + [f"nm{x}" for x in w]
    rows = [[f'"{n}"'] + values(c, w, scale=100.0) for _, n, c in curves]
    write("spectral_percent_5nm_crlf.txt", cgats(HEADER, fields, rows, eol="\r\n", first_line=None))

    # 3. R_ columns, 20 nm 360-740, SAMPLE_ID only.
    w = grid(360, 740, 20)
    fields = ["SAMPLE_ID"] + [f"R_{x}" for x in w]
    rows = [[i] + values(c, w) for i, _, c in curves]
    write("spectral_r_20nm.cgats", cgats(HEADER, fields, rows))

    # 4. SPECTRAL_NM columns (no underscore), percent stated in the header, a dark
    #    sample whose values alone would read as fractions.
    w = grid(400, 700, 10)
    fields = ["SAMPLE_ID", "SAMPLE_NAME"] + [f"SPECTRAL_NM{x}" for x in w]
    rows = [["1", '"Jet black"'] + values(lambda x: 0.012 + 0.00001 * (x - 400), w, scale=100.0)]
    write("spectral_percent_header.cgats", cgats(HEADER + ['REFLECTANCE_SCALE "PERCENT"'], fields, rows))

    # 5. Lab only, D50/2° from WEIGHTING_FUNCTION.
    fields = ["SAMPLE_ID", "SAMPLE_NAME", "LAB_L", "LAB_A", "LAB_B"]
    rows = [["1", '"Signal red"', "42.10", "58.30", "38.70"], ["2", '"Deep blue"', "25.40", "8.90", "-38.20"]]
    write("lab_only_d50.cgats", cgats(
        HEADER + ['WEIGHTING_FUNCTION "ILLUMINANT, D50"', 'WEIGHTING_FUNCTION "OBSERVER, 2 degree"'],
        fields, rows))

    # 6. XYZ only, D65/10° from ILLUMINANT and OBSERVER.
    fields = ["SAMPLE_ID", "XYZ_X", "XYZ_Y", "XYZ_Z"]
    rows = [["white", "94.811", "100.000", "107.304"], ["grey", "17.8", "18.8", "20.2"]]
    write("xyz_only_d65.cgats", cgats(HEADER + ["ILLUMINANT D65", "OBSERVER 10"], fields, rows))

    # 7-9. Multi-angle: geometry field, geometry in the name, aspecular field.
    w = grid(400, 700, 10)
    spec = [f"SPECTRAL_NM_{x}" for x in w]
    rows = [[f'"{n}"', f"45as{a}"] + values(c, w, factor=FLOP[a])
            for _, n, c in curves[:2] for a in ANGLES]
    write("multi_angle_geometry_field.cgats", cgats(HEADER, ["SAMPLE_NAME", "GEOMETRY"] + spec, rows))
    rows = [[f"RED_45as{a}"] + values(red, w, factor=FLOP[a]) for a in ANGLES]
    write("multi_angle_in_names.cgats", cgats(HEADER, ["SAMPLE_NAME"] + spec, rows))
    rows = [["RED", str(a)] + values(red, w, factor=FLOP[a]) + [("92.0" if a == 15 else "0")]
            for a in ANGLES]
    write("multi_angle_aspecular_field.cgats", cgats(
        HEADER + ["ILLUMINATION_ANGLE 45"], ["SAMPLE_NAME", "ASPECULAR"] + spec + ["GLOSS_20"], rows))

    # Malformed CGATS, each from a good file with one thing broken.
    good = cgats(HEADER, ["SAMPLE_NAME"] + spec,
                 [[f'"{n}"'] + values(c, w) for _, n, c in curves])
    lines = good.split("\n")
    # Cut in the middle of the second data row.
    data = lines.index("BEGIN_DATA")
    cut = lines[: data + 2] + [lines[data + 2][:60]]
    write("bad_truncated.cgats", "\n".join(cut))
    write("bad_missing_end_data.cgats", good.replace("END_DATA\n", ""))
    write("bad_number_of_fields.cgats", good.replace(f"NUMBER_OF_FIELDS {len(spec) + 1}", f"NUMBER_OF_FIELDS {len(spec)}"))
    write("bad_number_of_sets.cgats", good.replace("NUMBER_OF_SETS 3", "NUMBER_OF_SETS 4"))
    write("bad_not_a_number.cgats", good.replace(values(blue, w)[5], "0.1O7", 1))
    write("bad_geometry.cgats", cgats(HEADER, ["SAMPLE_NAME", "GEOMETRY"] + spec,
                                      [['"Red"', "45as15"] + values(red, w), ['"Red"', "d:45"] + values(red, w)]))

    write_cxf()


CXF_HEAD = '<?xml version="1.0" encoding="UTF-8"?>\n<!-- Synthetic spectra, written by tools/make_measurement_fixtures.py -->\n<cc:CxF xmlns:cc="http://colorexchangeformat.com/CxF3-core">\n'
CREATED = "2026-01-01T12:00:00Z"


def spec_xml(id_, geometry_xml, start=400, step=10, illuminant="D65", observer="10_Degree", method="E308_Table6"):
    return f"""      <cc:ColorSpecification Id="{id_}">
        <cc:TristimulusSpec>
          <cc:Illuminant>{illuminant}</cc:Illuminant>
          <cc:Observer>{observer}</cc:Observer>
          <cc:Method>{method}</cc:Method>
        </cc:TristimulusSpec>
        <cc:MeasurementSpec>
          <cc:MeasurementType>Spectrum_Reflectance</cc:MeasurementType>
          <cc:GeometryChoice>
{geometry_xml}
          </cc:GeometryChoice>
          <cc:WavelengthRange StartWL="{start}" Increment="{step}"/>
        </cc:MeasurementSpec>
      </cc:ColorSpecification>
"""


def cxf(objects, specs):
    return (CXF_HEAD + "  <cc:Resources>\n    <cc:ObjectCollection>\n" + objects
            + "    </cc:ObjectCollection>\n    <cc:ColorSpecificationCollection>\n" + specs
            + "    </cc:ColorSpecificationCollection>\n  </cc:Resources>\n</cc:CxF>\n")


def brdf(a, indent=14):
    pad = " " * indent
    return (f'{pad}<cc:BRDFAngle Notation="45as{a}">\n{pad}  <cc:IlluminationAngle>45</cc:IlluminationAngle>\n'
            f"{pad}  <cc:Aspecular>{a}</cc:Aspecular>\n{pad}</cc:BRDFAngle>")


def spectrum(sid, numbers, name=None):
    named = f' Name="{name}"' if name else ""
    return (f'          <cc:ReflectanceSpectrum ColorSpecification="{sid}"{named}>'
            + " ".join(numbers) + "</cc:ReflectanceSpectrum>\n")


LAB_45 = ('          <cc:ColorCIELab ColorSpecification="CS_45as45"><cc:L>40.0</cc:L>'
          "<cc:A>50.0</cc:A><cc:B>30.0</cc:B></cc:ColorCIELab>\n")


def write_cxf():
    """The instrument-like files follow X-Rite's CxF3 core schema (they validate
    against vendor/cxf3/CxF3_Core.xsd); earlier_layout.cxf holds the same readings
    in the layout Coatlab's exports wrote before they followed it; the bad_ files
    are broken on purpose."""
    w = grid(400, 700, 10)
    w5 = grid(360, 780, 5)
    sphere_factors = [("CS_SCI", 1.0), ("CS_SCE", 0.97), ("CS_45_0", 0.96)]

    # Multi-angle: one ColorSpecification per angle, a MultiAngle of one BRDFAngle,
    # except 75° and 110°, two BRDFAngles of one specification that each spectrum
    # picks by its Name; Lab beside the 45° spectrum; gloss in PhysicalAttributes,
    # the angle in the Method.
    specs = ""
    for a in ANGLES[:-2]:
        specs += spec_xml(f"CS_45as{a}", f"            <cc:MultiAngle>\n{brdf(a)}\n            </cc:MultiAngle>")
    specs += spec_xml("CS_45flop", f"            <cc:MultiAngle>\n{brdf(75)}\n{brdf(110)}\n            </cc:MultiAngle>")
    objects = ""
    for i, n, c in [("R1", "Signal red", red), ("B2", "Deep blue", blue)]:
        objects += (f'      <cc:Object ObjectType="Standard" Name="{n}" Id="{i}">\n'
                    f"        <cc:CreationDate>{CREATED}</cc:CreationDate>\n        <cc:ColorValues>\n")
        for a in ANGLES:
            sid, name = (f"CS_45as{a}", None) if a < 75 else ("CS_45flop", f"45as{a}")
            objects += spectrum(sid, values(c, w, factor=FLOP[a]), name)
        objects += LAB_45
        objects += ("        </cc:ColorValues>\n        <cc:PhysicalAttributes>\n"
                    '          <cc:Gloss Method="ISO 2813, 20°">88.5</cc:Gloss>\n'
                    '          <cc:Gloss Method="60">93.0</cc:Gloss>\n'
                    "        </cc:PhysicalAttributes>\n      </cc:Object>\n")
    write("multi_angle.cxf", cxf(objects, specs))

    # Sphere SCI and SCE, 45:0 single angle, 5 nm from 360 nm.
    specs = spec_xml("CS_SCI", "            <cc:SphereGeometry>Specular_Included</cc:SphereGeometry>", 360, 5)
    specs += spec_xml("CS_SCE", "            <cc:SphereGeometry>Specular_Excluded</cc:SphereGeometry>", 360, 5)
    specs += spec_xml("CS_45_0", "            <cc:SingleAngle>\n              <cc:SingleAngleConfiguration>Annular</cc:SingleAngleConfiguration>\n              <cc:IlluminationAngle>45</cc:IlluminationAngle>\n              <cc:MeasurementAngle>0</cc:MeasurementAngle>\n            </cc:SingleAngle>", 360, 5)
    objects = (f'      <cc:Object ObjectType="Standard" Name="Grey panel" Id="G1">\n'
               f"        <cc:CreationDate>{CREATED}</cc:CreationDate>\n        <cc:ColorValues>\n")
    for sid, f in sphere_factors:
        objects += spectrum(sid, values(grey, w5, factor=f))
    objects += "        </cc:ColorValues>\n      </cc:Object>\n"
    good = cxf(objects, specs)
    write("sphere_and_45_0.cxf", good)

    # Malformed CxF.
    write("bad_truncated.cxf", good[: len(good) // 2])
    write("bad_geometry.cxf", good.replace(
        "<cc:SphereGeometry>Specular_Excluded</cc:SphereGeometry>",
        '<cc:ConeGeometry HalfAngle="5"/>'))
    write("bad_number.cxf", good.replace("0.4200", "0.42.00", 1) if "0.4200" in good
          else good.replace(values(grey, w5)[3], "n/a", 1))
    bomb = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!-- An entity-expansion bomb, written by tools/make_measurement_fixtures.py -->\n <!ENTITY lol "lol">\n'
            + "".join(f' <!ENTITY lol{k} "{("&lol%s;" % ("" if k == 1 else k - 1)) * 10}">\n' for k in range(1, 10))
            + ']>\n<cc:CxF xmlns:cc="http://colorexchangeformat.com/CxF3-core"><cc:Resources>'
            '<cc:ObjectCollection><cc:Object Name="&lol9;"/></cc:ObjectCollection></cc:Resources></cc:CxF>\n')
    write("bad_xml_bomb.cxf", bomb)

    # The same readings in Coatlab's earlier layout (not schema-valid): the angles
    # directly in MultiAngle, or as attributes of a bare BRDFAngle (110°); the sphere
    # as a SpecularComponentIncluded child or a SpecularComponent attribute; gloss
    # with an Angle attribute in ColorValues; no CreationDate; Method E308.
    specs = ""
    for a in ANGLES:
        if a == 110:
            g = f'            <cc:BRDFAngle IlluminationAngle="45" Aspecular="{a}"/>'
        else:
            g = (f"            <cc:MultiAngle>\n              <cc:IlluminationAngle>45</cc:IlluminationAngle>\n"
                 f"              <cc:Aspecular>{a}</cc:Aspecular>\n            </cc:MultiAngle>")
        specs += spec_xml(f"CS_45as{a}", g, method="E308")
    specs += spec_xml("CS_SCI", "            <cc:SphereGeometry>\n              <cc:SpecularComponentIncluded>true</cc:SpecularComponentIncluded>\n            </cc:SphereGeometry>", 360, 5, method="E308")
    specs += spec_xml("CS_SCE", '            <cc:SphereGeometry SpecularComponent="Excluded"/>', 360, 5, method="E308")
    specs += spec_xml("CS_45_0", "            <cc:SingleAngle>\n              <cc:IlluminationAngle>45</cc:IlluminationAngle>\n              <cc:MeasurementAngle>0</cc:MeasurementAngle>\n            </cc:SingleAngle>", 360, 5, method="E308")
    objects = ""
    for i, n, c in [("R1", "Signal red", red), ("B2", "Deep blue", blue)]:
        objects += f'      <cc:Object ObjectType="Standard" Name="{n}" Id="{i}">\n        <cc:ColorValues>\n'
        for a in ANGLES:
            objects += spectrum(f"CS_45as{a}", values(c, w, factor=FLOP[a]))
        objects += LAB_45
        objects += '          <cc:Gloss Angle="20">88.5</cc:Gloss>\n          <cc:Gloss Angle="60">93.0</cc:Gloss>\n'
        objects += "        </cc:ColorValues>\n      </cc:Object>\n"
    objects += '      <cc:Object ObjectType="Standard" Name="Grey panel" Id="G1">\n        <cc:ColorValues>\n'
    for sid, f in sphere_factors:
        objects += spectrum(sid, values(grey, w5, factor=f))
    objects += "        </cc:ColorValues>\n      </cc:Object>\n"
    write("earlier_layout.cxf", cxf(objects, specs))


if __name__ == "__main__":
    main()
