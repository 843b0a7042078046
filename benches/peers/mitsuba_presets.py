"""Prints the RGB conductor and dielectric presets of the installed Mitsuba 3 (scalar_rgb): the
tables in crates/scene/src/mitsuba/presets.rs were generated with it (Mitsuba 3.9.1).

    pip install mitsuba && python3 benches/peers/mitsuba_presets.py
"""
import mitsuba as mi

mi.set_variant("scalar_rgb")

CONDUCTORS = ("a-C Ag Al AlAs AlAs_palik AlSb AlSb_palik Au Be Cr CsI Cu Cu_palik Cu2O CuO d-C Hg "
              "HgTe Ir K Li MgO Mo Na_palik Nb Ni_palik Rh Se SiC SnTe Ta Te ThF4 TiC TiN TiO2 VC "
              "V_palik VN W").split()
DIELECTRICS = ["vacuum", "helium", "hydrogen", "air", "carbon dioxide", "water", "acetone",
               "ethanol", "carbon tetrachloride", "glycerol", "benzene", "silicone oil", "bromine",
               "water ice", "fused quartz", "pyrex", "acrylic glass", "polypropylene", "bk7",
               "sodium chloride", "amber", "pet", "diamond"]


def rgb(v):
    return "Rgb::new({:.6}, {:.6}, {:.6})".format(*[max(0.0, float(x)) for x in v])


print(f"// Mitsuba {mi.__version__}, scalar_rgb")
for name in CONDUCTORS:
    p = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
    print(f'    ("{name}", {rgb(p["eta.value"])}, {rgb(p["k.value"])}),')
for name in DIELECTRICS:
    p = mi.traverse(mi.load_dict({"type": "dielectric", "int_ior": name, "ext_ior": "vacuum"}))
    print(f'    ("{name}", {float(p["eta"]):.6}),')
