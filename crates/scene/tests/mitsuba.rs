//! The Mitsuba 3 XML importer, element by element: each test writes a small scene (and its mesh or
//! included files) to a fresh directory and checks what Lightlab's description holds, or that the
//! error names the right file, line and column. Deterministic.

use glam::DVec3;
use lightlab_core::Rgb;
use lightlab_scene::SceneError;
use lightlab_scene::desc::{GeometryRaw, LightRaw, MaterialRaw, Microfacets, Roughness};
use lightlab_scene::mitsuba::{Imported, import};
use std::path::PathBuf;

/// A fresh directory for one test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lightlab-mitsuba-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>
        <rfilter type="box"/></film></sensor>"#;

/// Imports `body` (the contents of `<scene>`) written as `name`.xml, with `defines`. The image
/// files it names (`.exr`, `.png`) are created empty beside it — the importer only checks that
/// they exist; the loader reads them — except those whose names start with `missing`.
fn import_in(name: &str, body: &str, defines: &[(&str, &str)]) -> Result<Imported, SceneError> {
    let d = dir(name);
    for part in body.split("value=\"").skip(1) {
        let file = part.split('"').next().unwrap();
        if (file.ends_with(".exr") || file.ends_with(".png")) && !file.starts_with("missing") {
            std::fs::write(d.join(file), b"").unwrap();
        }
    }
    let path = d.join("scene.xml");
    std::fs::write(
        &path,
        format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n"),
    )
    .unwrap();
    let defines: Vec<(String, String)> = defines
        .iter()
        .map(|(n, v)| (n.to_string(), v.to_string()))
        .collect();
    import(&path, &defines)
}

fn ok(name: &str, body: &str) -> Imported {
    import_in(name, body, &[]).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The error's line, column and message.
fn err(name: &str, body: &str) -> (usize, usize, String) {
    match import_in(name, body, &[]) {
        Err(SceneError::Invalid {
            line, col, message, ..
        }) => (line, col, message),
        Err(e) => panic!("{name}: not a located error: {e}"),
        Ok(_) => panic!("{name}: imported, but an error was expected"),
    }
}

fn material(i: &Imported, name: &str) -> (MaterialRaw, bool) {
    let (_, m) = i
        .desc
        .materials
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no material {name}: {:?}", i.desc.materials));
    (m.raw.clone(), m.one_sided)
}

/// The corners of each triangle of a mesh.
fn triangles<'a>(
    positions: &'a [DVec3],
    indices: &'a [(u32, u32, u32)],
) -> impl Iterator<Item = [DVec3; 3]> + 'a {
    indices
        .iter()
        .map(|&(a, b, c)| [a, b, c].map(|k| positions[k as usize]))
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-9 * (1.0 + b.length())
}

#[test]
fn defaults_are_substituted_and_overridden_by_defines() {
    let body = r#"<default name="spp" value="7"/><default name="res" value="24"/>
        <sensor type="perspective"><float name="fov" value="40"/>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/>
        <rfilter type="box"/></film></sensor>"#;
    let i = ok("defaults", body);
    assert_eq!(i.spp, Some(7));
    assert_eq!(i.desc.camera.resolution, (24, 24));
    let i = import_in("defines", body, &[("spp", "9")]).unwrap();
    assert_eq!(i.spp, Some(9));
    assert_eq!(i.desc.camera.resolution, (24, 24));
    // A -D the scene never uses is a typo.
    let e = import_in("unused-define", body, &[("sp", "9")]).unwrap_err();
    assert!(e.to_string().contains("never refers to $sp"), "{e}");
    // An undefined $name is located.
    let (line, _, m) = err(
        "undefined",
        &format!(
            "{SENSOR}\n<emitter type=\"constant\"><rgb name=\"radiance\" value=\"$sky\"/></emitter>"
        ),
    );
    assert_eq!(line, 5);
    assert!(m.contains("$sky is not defined"), "{m}");
}

#[test]
fn malformed_xml_and_unknown_parameters_are_located() {
    let (line, _, m) = err("malformed", &format!("{SENSOR}\n<bsdf type=\"diffuse\">\n"));
    assert!(line >= 5 && m.contains("not well-formed"), "{line}: {m}");
    // A file that stops inside its root element was located at 1:1: now where it stops.
    let truncated = dir("truncated").join("scene.xml");
    std::fs::write(
        &truncated,
        format!("<scene version=\"3.0.0\">\n{SENSOR}\n<bsdf"),
    )
    .unwrap();
    match import(&truncated, &[]) {
        Err(SceneError::Invalid { line, message, .. }) => assert!(
            line == 5 && message.contains("ends before its root element closes"),
            "{line}: {message}"
        ),
        other => panic!("{other:?}"),
    }
    let (line, col, m) = err(
        "unknown-param",
        &format!(
            "{SENSOR}\n<bsdf type=\"diffuse\" id=\"a\">\n    <float name=\"roughness\" value=\"0.2\"/>\n</bsdf>"
        ),
    );
    assert_eq!((line, col), (6, 5), "{m}");
    assert!(
        m.contains("parameter 'roughness'") && m.contains("diffuse"),
        "{m}"
    );
    let (_, _, m) = err(
        "twice",
        &format!(
            "{SENSOR}<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1\"/><rgb name=\"reflectance\" value=\"0.2\"/></bsdf>"
        ),
    );
    assert!(m.contains("given twice"), "{m}");
    // Nesting is bounded (20 000 nested two-sided wrappers overflowed the stack).
    let deep = format!(
        "{SENSOR}<bsdf type=\"diffuse\" id=\"d\">{}{}</bsdf>",
        "<bsdf type=\"twosided\">".repeat(20_000),
        "</bsdf>".repeat(20_000)
    );
    let (_, _, m) = err("deep", &deep);
    assert!(m.contains("nested more than 64 deep"), "{m}");
    let (_, _, m) = err("no-sensor", "<emitter type=\"constant\"/>");
    assert!(m.contains("no <sensor>"), "{m}");
    let d = dir("old-version");
    std::fs::write(d.join("old.xml"), "<scene version=\"0.5.0\">\n</scene>").unwrap();
    let e = import(&d.join("old.xml"), &[]).unwrap_err().to_string();
    assert!(
        e.contains("old.xml:1:1") && e.contains("Mitsuba 0.x"),
        "{e}"
    );
}

#[test]
fn unsupported_plugins_are_errors_naming_what_is_supported() {
    for (name, body, expect) in [
        (
            "blendbsdf",
            "<bsdf type=\"blendbsdf\"/>",
            "BSDF type 'blendbsdf'",
        ),
        (
            "anisotropic-roughplastic",
            "<bsdf type=\"roughplastic\"><float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.3\"/></bsdf>",
            "RoughPlastic roughness must be Isotropic",
        ),
        (
            "shapegroup",
            "<shape type=\"shapegroup\"/>",
            "shape type 'shapegroup'",
        ),
        (
            "directional-both",
            "<emitter type=\"directional\"><vector name=\"direction\" value=\"0, -1, 0\"/><transform name=\"to_world\"/></emitter>",
            "direction or to_world, not both",
        ),
        (
            "directional-zero",
            "<emitter type=\"directional\"><vector name=\"direction\" value=\"0, 0, 0\"/></emitter>",
            "Directional direction must be non-zero",
        ),
        ("mask", "<bsdf type=\"mask\"/>", "BSDF type 'mask'"),
        (
            "texture",
            "<texture type=\"noise\" id=\"t\"/>",
            "texture type 'noise' is not imported",
        ),
        (
            "tex-param",
            "<bsdf type=\"dielectric\"><texture name=\"specular_reflectance\" type=\"checkerboard\"/></bsdf>",
            "a texture for 'specular_reflectance'",
        ),
        (
            "spectrum",
            "<bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"400:0.1, 700:0.5\"/></bsdf>",
            "sampled spectrum",
        ),
    ] {
        let (_, _, m) = err(name, &format!("{SENSOR}\n{body}"));
        assert!(m.contains(expect), "{name}: {m}");
    }
}

#[test]
fn includes_and_references_resolve() {
    let d = dir("include");
    std::fs::write(
        d.join("materials.xml"),
        r#"<scene version="3.0.0"><bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.25"/></bsdf></scene>"#,
    )
    .unwrap();
    std::fs::write(
        d.join("scene.xml"),
        format!(
            r#"<scene version="3.0.0">{SENSOR}<include filename="materials.xml"/>
            <shape type="sphere"><ref id="grey"/></shape></scene>"#
        ),
    )
    .unwrap();
    let i = import(&d.join("scene.xml"), &[]).unwrap();
    assert_eq!(i.desc.shapes[0].material, "grey");
    assert_eq!(
        material(&i, "grey").0,
        MaterialRaw::Diffuse {
            albedo: Rgb::splat(0.25).into()
        }
    );
    // A file that includes itself.
    std::fs::write(
        d.join("loop.xml"),
        r#"<scene version="3.0.0"><include filename="loop.xml"/></scene>"#,
    )
    .unwrap();
    let e = import(&d.join("loop.xml"), &[]).unwrap_err();
    assert!(e.to_string().contains("includes itself"), "{e}");
    // …also through a path that names it another way (it recursed 584 levels deep before).
    std::fs::create_dir_all(d.join("sub")).unwrap();
    std::fs::write(
        d.join("dotdot.xml"),
        r#"<scene version="3.0.0"><include filename="sub/../dotdot.xml"/></scene>"#,
    )
    .unwrap();
    let e = import(&d.join("dotdot.xml"), &[]).unwrap_err();
    assert!(e.to_string().contains("includes itself"), "{e}");
    // A chain of files each including the next twice (2^depth reads) stops at the include limit.
    for k in 0..16 {
        std::fs::write(
            d.join(format!("twice{k}.xml")),
            format!(
                r#"<scene version="3.0.0"><include filename="twice{0}.xml"/><include filename="twice{0}.xml"/></scene>"#,
                k + 1
            ),
        )
        .unwrap();
    }
    std::fs::write(d.join("twice16.xml"), r#"<scene version="3.0.0"/>"#).unwrap();
    let e = import(&d.join("twice0.xml"), &[]).unwrap_err();
    assert!(e.to_string().contains("more than 4096 files"), "{e}");
    let (_, _, m) = err(
        "missing-ref",
        &format!("{SENSOR}<shape type=\"sphere\"><ref id=\"nope\"/></shape>"),
    );
    assert!(m.contains("no element has this id"), "{m}");
    let (_, _, m) = err(
        "wrong-ref",
        &format!(
            "{SENSOR}<emitter type=\"constant\" id=\"sky\"/><shape type=\"sphere\"><ref id=\"sky\"/></shape>"
        ),
    );
    assert!(m.contains("names a <emitter>"), "{m}");
}

#[test]
fn transforms_compose_in_order_like_mitsuba() {
    // scale 2, then +90° about z (x → y), then translate (1, 2, 3): corner (−1, −1) → (−2, −2)
    // → (2, −2) → (3, 0, 3).
    let i = ok(
        "transforms",
        &format!(
            r#"{SENSOR}<shape type="rectangle"><transform name="to_world">
            <scale value="2"/><rotate z="1" angle="90"/><translate x="1" y="2" z="3"/>
            </transform></shape>
            <shape type="rectangle"><transform name="to_world">
            <matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/></transform></shape>"#
        ),
    );
    let GeometryRaw::Mesh {
        positions, indices, ..
    } = &i.desc.shapes[0].geometry.0
    else {
        panic!("{:?}", i.desc.shapes[0].geometry)
    };
    assert!(
        close(positions[0], DVec3::new(3.0, 0.0, 3.0)),
        "{positions:?}"
    );
    // The front of each triangle is the rotated +z: still +z.
    for [a, b, c] in triangles(positions, indices) {
        assert!((b - a).cross(c - a).normalize().z > 0.999);
    }
    // The matrix is row-major in the file: its last column is the translation.
    let GeometryRaw::Mesh { positions, .. } = &i.desc.shapes[1].geometry.0 else {
        panic!()
    };
    assert!(
        close(positions[0], DVec3::new(4.0, 5.0, 7.0)),
        "{positions:?}"
    );
    // Mitsuba does not normalise a rotation axis: this cube's corner (1, −1, −1) lands where
    // Mitsuba 3.9.1 puts it (its `vertex_positions`), not where a rigid rotation would.
    let i = ok(
        "unnormalised-axis",
        &format!(
            r#"{SENSOR}<shape type="cube"><transform name="to_world"><scale value="0.15"/>
            <rotate x="1" y="1" angle="30"/><translate x="0.5" y="-0.05" z="0.3"/></transform></shape>"#
        ),
    );
    let GeometryRaw::Mesh { positions, .. } = &i.desc.shapes[0].geometry.0 else {
        panic!()
    };
    let mitsuba = DVec3::new(0.5549038, -0.10490382, 0.0200962);
    assert!(
        positions.iter().any(|p| (*p - mitsuba).length() < 1e-6),
        "{positions:?}"
    );
    // A projective matrix (a bottom row other than 0 0 0 1) is refused, not dropped.
    for row in ["0 0 0 2", "0.3 0 0 1"] {
        let (line, _, message) = err(
            "projective",
            &format!(
                r#"{SENSOR}<shape type="rectangle"><transform name="to_world">
                <matrix value="1 0 0 0  0 1 0 0  0 0 1 0  {row}"/></transform></shape>"#
            ),
        );
        assert!(
            line > 1 && message.contains("bottom row must be 0 0 0 1"),
            "{line}: {message}"
        );
    }
}

#[test]
fn sensors_map_fov_axes_lenses_and_mirrors() {
    let sensor = |extra: &str, kind: &str| {
        format!(
            r#"<sensor type="{kind}">{extra}
            <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="32"/>
            <rfilter type="box"/></film></sensor>"#
        )
    };
    let fov = |extra: &str| ok("fov", &sensor(extra, "perspective")).desc.camera.fov as f64;
    // The shutter is imported (it was documented but refused as an unknown parameter).
    let shutter =
        r#"<float name="shutter_open" value="0.25"/><float name="shutter_close" value="0.75"/>"#;
    let lens =
        r#"<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="4"/>"#;
    for (kind, extra) in [("perspective", ""), ("thinlens", lens)] {
        let c = ok("shutter", &sensor(&format!("{shutter}{extra}"), kind))
            .desc
            .camera;
        assert_eq!(c.shutter, (0.25, 0.75), "{kind}");
    }
    let smaller = |axis_fov: f64, extent: f64| {
        2.0 * ((axis_fov.to_radians() / 2.0).tan() * 32.0 / extent)
            .atan()
            .to_degrees()
    };
    let cases = [
        (r#"<float name="fov" value="90"/>"#, smaller(90.0, 64.0)),
        (
            r#"<float name="fov" value="50"/><string name="fov_axis" value="y"/>"#,
            50.0,
        ),
        (
            r#"<float name="fov" value="60"/><string name="fov_axis" value="diagonal"/>"#,
            smaller(60.0, 64f64.hypot(32.0)),
        ),
        (
            r#"<float name="fov" value="30"/><string name="fov_axis" value="larger"/>"#,
            smaller(30.0, 64.0),
        ),
        // 50 mm on 35 mm film: Mitsuba's default when no fov is given.
        (
            "",
            smaller(
                2.0 * (36f64.hypot(24.0) / 100.0).atan().to_degrees(),
                64f64.hypot(32.0),
            ),
        ),
    ];
    for (extra, want) in cases {
        let got = fov(extra);
        assert!((got - want).abs() < 1e-4, "{extra}: fov {got} vs {want}");
    }
    let c = ok(
        "camera",
        &sensor(r#"<float name="fov" value="40"/>"#, "perspective"),
    )
    .desc
    .camera;
    assert!(close(c.eye, DVec3::new(0.0, 0.0, 4.0)) && close(c.target, DVec3::new(0.0, 0.0, 3.0)));
    assert!(!c.mirrored);
    let c = ok(
        "thinlens",
        &sensor(
            r#"<float name="fov" value="40"/><float name="aperture_radius" value="0.1"/>
            <float name="focus_distance" value="3.5"/>"#,
            "thinlens",
        ),
    )
    .desc
    .camera;
    assert_eq!(
        c.lens,
        lightlab_scene::desc::Lens::ThinLens {
            aperture_radius: 0.1,
            focus_distance: 3.5
        }
    );
    // A bad fov_axis names the values allowed; without fov there is nothing for it to apply to.
    let (_, _, m) = err(
        "fov-axis-value",
        r#"<sensor type="perspective"><float name="fov" value="40"/><string name="fov_axis" value="q"/></sensor>"#,
    );
    assert!(
        m.contains("not one of x, y, diagonal, smaller, larger"),
        "{m}"
    );
    let (_, _, m) = err(
        "fov-axis-alone",
        r#"<sensor type="perspective"><string name="fov_axis" value="y"/></sensor>"#,
    );
    assert!(m.contains("fov_axis applies to fov only"), "{m}");
    // A reflecting sensor transform mirrors the image.
    let mirrored = r#"<sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><scale x="-1"/></transform></sensor>"#;
    assert!(ok("mirrored", mirrored).desc.camera.mirrored);
    // Mitsuba's default film is 768 × 576 with a Gaussian filter, which is noted.
    let i = ok(
        "default-film",
        r#"<sensor type="perspective"><float name="fov" value="40"/></sensor>"#,
    );
    assert_eq!(i.desc.camera.resolution, (768, 576));
    assert!(
        i.notes.iter().any(|n| n.contains("gaussian")),
        "{:?}",
        i.notes
    );
    // Clipping planes are read but not applied, which is noted where a file sets them.
    let clipped = ok(
        "clipped",
        &SENSOR.replace("<film", r#"<float name="near_clip" value="0.5"/><film"#),
    );
    assert!(
        clipped.notes.iter().any(|n| n.contains("does not clip")),
        "{:?}",
        clipped.notes
    );
    assert!(
        !ok("unclipped", SENSOR)
            .notes
            .iter()
            .any(|n| n.contains("clip"))
    );
}

#[test]
fn integrators_map_max_depth_to_bounces() {
    let integ = |xml: &str| {
        ok("integrator", &format!("{SENSOR}{xml}"))
            .integrator
            .unwrap()
            .map_err(|e| e.to_string())
    };
    assert_eq!(
        integ(r#"<integrator type="path"><integer name="max_depth" value="6"/></integrator>"#)
            .unwrap(),
        "Path(max_bounces: Some(5), russian_roulette: Some(5), roulette_threshold: 1.0)"
    );
    assert_eq!(
        integ(r#"<integrator type="volpath"><integer name="rr_depth" value="2"/></integrator>"#)
            .unwrap(),
        "Path(max_bounces: None, russian_roulette: Some(2), roulette_threshold: 1.0)"
    );
    assert_eq!(
        integ(r#"<integrator type="direct"/>"#).unwrap(),
        "Path(max_bounces: Some(1))"
    );
    assert!(
        integ(r#"<integrator type="path"><integer name="max_depth" value="0"/></integrator>"#)
            .unwrap_err()
            .contains("max_depth")
    );
    // Beyond u32 it said only "Integer is out of bounds", at a column of the generated RON.
    let e = integ(
        r#"<integrator type="path"><integer name="max_depth" value="99999999999999"/></integrator>"#,
    )
    .unwrap_err();
    assert!(
        e.contains("max_depth must be −1 (unlimited) or 1…4294967295"),
        "{e}"
    );
    assert!(
        integ(r#"<integrator type="aov"/>"#)
            .unwrap_err()
            .contains("'aov'")
    );
    assert!(ok("no-integrator", SENSOR).integrator.is_none());
}

#[test]
fn mesh_files_get_mitsuba_normals() {
    let d = dir("meshes");
    // Two triangles folded along the shared edge (0, 1): no normals in the file.
    std::fs::write(
        d.join("fold.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\n",
    )
    .unwrap();
    std::fs::write(
        d.join("tri.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    )
    .unwrap();
    let body = format!(
        r#"{SENSOR}
        <shape type="obj"><string name="filename" value="fold.obj"/></shape>
        <shape type="obj"><string name="filename" value="fold.obj"/><boolean name="face_normals" value="true"/></shape>
        <shape type="ply"><string name="filename" value="tri.ply"/>
            <transform name="to_world"><translate z="2"/></transform></shape>
        <shape type="ply"><string name="filename" value="tri.ply"/><boolean name="flip_normals" value="true"/></shape>"#
    );
    std::fs::write(
        d.join("scene.xml"),
        format!("<scene version=\"3.0.0\">{body}</scene>"),
    )
    .unwrap();
    let i = import(&d.join("scene.xml"), &[]).unwrap();
    let mesh = |k: usize| match &i.desc.shapes[k].geometry.0 {
        GeometryRaw::Mesh {
            positions,
            indices,
            normals,
            ..
        } => (positions.clone(), indices.clone(), normals.clone()),
        g => panic!("{g:?}"),
    };
    let (_, _, normals) = mesh(0);
    let n = normals.expect("computed vertex normals");
    // Vertex 0 sees both faces at 90°: the normal is their average, (0, 1, 1)/√2 (faces (0, 0, 1)
    // and (0, 1, 0)).
    let want = glam::Vec3::new(0.0, 1.0, 1.0).normalize();
    assert!((n[0] - want).length() < 1e-6, "{}", n[0]);
    assert!((n[2] - glam::Vec3::Z).length() < 1e-6, "{}", n[2]);
    assert!(mesh(1).2.is_none(), "face_normals keeps flat normals");
    // The PLY quad is fan-triangulated and moved by to_world.
    let (p, idx, _) = mesh(2);
    assert_eq!(idx, vec![(0, 1, 2), (0, 2, 3)]);
    assert!(close(p[2], DVec3::new(1.0, 1.0, 2.0)));
    // flip_normals reverses the winding and the normals.
    let (_, idx, n) = mesh(3);
    assert_eq!(idx, vec![(0, 2, 1), (0, 3, 2)]);
    assert!((n.unwrap()[0] + glam::Vec3::Z).length() < 1e-6);
    let (_, _, m) = err(
        "missing-mesh",
        &format!(
            "{SENSOR}<shape type=\"obj\"><string name=\"filename\" value=\"none.obj\"/></shape>"
        ),
    );
    assert!(m.contains("does not exist"), "{m}");
}

#[test]
fn cubes_face_outward_and_spheres_take_their_transform() {
    let i = ok(
        "cube-sphere",
        &format!(
            r#"{SENSOR}<shape type="cube"><transform name="to_world"><scale x="2" y="1" z="0.5"/>
            <translate x="10"/></transform></shape>
            <shape type="sphere"><point name="center" x="1" y="0" z="0"/><float name="radius" value="2"/>
            <transform name="to_world"><scale value="3"/><translate y="1"/></transform></shape>"#
        ),
    );
    let GeometryRaw::Mesh {
        positions, indices, ..
    } = &i.desc.shapes[0].geometry.0
    else {
        panic!()
    };
    assert_eq!(indices.len(), 12);
    let centre = DVec3::new(10.0, 0.0, 0.0);
    for [a, b, c] in triangles(positions, indices) {
        let n = (b - a).cross(c - a);
        assert!(
            n.dot((a + b + c) / 3.0 - centre) > 0.0,
            "inward face {a} {b} {c}"
        );
    }
    // The sphere is placed by its transform (which keeps its rotation for its (u, v)).
    let GeometryRaw::Sphere { center, radius } = i.desc.shapes[1].geometry.0 else {
        panic!()
    };
    let t = &i.desc.shapes[1].transform;
    assert!(
        center == DVec3::ZERO && close(t.translate, DVec3::new(3.0, 1.0, 0.0)) && radius == 6.0,
        "{center} {radius} {t:?}"
    );
    let (_, _, m) = err(
        "ellipsoid",
        &format!(
            "{SENSOR}<shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"2\"/></transform></shape>"
        ),
    );
    assert!(m.contains("ellipsoid"), "{m}");
    // Radii that are not a sphere's say so (they were blamed on a to_world the file did not have).
    for (radius, words) in [
        ("0", "radius must be > 0 and finite, got 0"),
        ("-1", "radius must be > 0 and finite, got -1"),
        ("1e-300", "beyond what 32-bit floats hold"),
    ] {
        let (_, _, m) = err(
            "radius",
            &format!(
                "{SENSOR}<shape type=\"sphere\"><float name=\"radius\" value=\"{radius}\"/></shape>"
            ),
        );
        assert!(m.contains(words), "{radius}: {m}");
    }
}

#[test]
fn bsdfs_keep_mitsuba_defaults_and_sidedness() {
    let i = ok(
        "bsdfs",
        &format!(
            r#"{SENSOR}
            <bsdf type="diffuse" id="d"/>
            <bsdf type="twosided" id="two"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf></bsdf>
            <bsdf type="conductor" id="mirror"/>
            <bsdf type="conductor" id="gold"><string name="material" value="Au"/></bsdf>
            <bsdf type="conductor" id="custom"><rgb name="eta" value="1, 2, 3"/><rgb name="k" value="0.5"/></bsdf>
            <bsdf type="roughconductor" id="rough"><string name="distribution" value="ggx"/>
                <float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.1"/></bsdf>
            <bsdf type="dielectric" id="water"><string name="int_ior" value="water"/></bsdf>
            <bsdf type="thindielectric" id="pane"><string name="int_ior" value="water"/><string name="ext_ior" value="vacuum"/></bsdf>
            <bsdf type="dielectric" id="inside"><float name="int_ior" value="1"/><float name="ext_ior" value="1.5"/></bsdf>
            <bsdf type="roughconductor" id="default-rough"/>
            <bsdf type="roughdielectric" id="frosted"><string name="distribution" value="ggx"/>
                <float name="alpha" value="0.2"/></bsdf>
            <bsdf type="plastic" id="plastic"/>
            <bsdf type="twosided" id="red-plastic"><bsdf type="plastic">
                <rgb name="diffuse_reflectance" value="0.8, 0.1, 0.1"/><rgb name="specular_reflectance" value="0.5"/>
                <float name="int_ior" value="1.9"/><float name="ext_ior" value="1.0"/><boolean name="nonlinear" value="true"/>
            </bsdf></bsdf>
            <bsdf type="roughplastic" id="rough-plastic"/>
            <bsdf type="roughplastic" id="ggx-plastic"><string name="distribution" value="ggx"/>
                <float name="alpha" value="0.3"/><float name="int_ior" value="1.5"/><float name="ext_ior" value="1"/>
                <boolean name="nonlinear" value="true"/></bsdf>"#
        ),
    );
    // Mitsuba's plastic defaults: diffuse 0.5, specular 1, polypropylene (1.49) in air, linear;
    // one-sided unless wrapped.
    let (plastic, one_sided) = material(&i, "plastic");
    let MaterialRaw::Plastic {
        kd,
        ks,
        ior,
        nonlinear,
    } = plastic
    else {
        panic!("{plastic:?}")
    };
    assert!(one_sided && !nonlinear);
    assert_eq!((kd, ks), (Rgb::splat(0.5).into(), Rgb::WHITE.into()));
    assert!((ior - 1.49 / 1.000277).abs() < 1e-5, "{ior}");
    assert_eq!(
        material(&i, "red-plastic"),
        (
            MaterialRaw::Plastic {
                kd: Rgb::new(0.8, 0.1, 0.1).into(),
                ks: Rgb::splat(0.5).into(),
                ior: 1.9,
                nonlinear: true
            },
            false
        )
    );
    // Mitsuba's roughplastic defaults: plastic's, with Beckmann normals of α = 0.1.
    let (rough, one_sided) = material(&i, "rough-plastic");
    let MaterialRaw::RoughPlastic {
        kd,
        ks,
        roughness,
        ior,
        distribution,
        nonlinear,
    } = rough
    else {
        panic!("{rough:?}")
    };
    assert!(one_sided && !nonlinear && distribution == Microfacets::Beckmann);
    assert_eq!((kd, ks), (Rgb::splat(0.5).into(), Rgb::WHITE.into()));
    assert_eq!(roughness, Roughness::Isotropic(0.1));
    assert!((ior - 1.49 / 1.000277).abs() < 1e-5, "{ior}");
    assert_eq!(
        material(&i, "ggx-plastic"),
        (
            MaterialRaw::RoughPlastic {
                kd: Rgb::splat(0.5).into(),
                ks: Rgb::WHITE.into(),
                roughness: Roughness::Isotropic(0.3),
                ior: 1.5,
                distribution: Microfacets::Ggx,
                nonlinear: true
            },
            true
        )
    );
    assert_eq!(
        material(&i, "d"),
        (
            MaterialRaw::Diffuse {
                albedo: Rgb::splat(0.5).into()
            },
            true
        )
    );
    assert_eq!(
        material(&i, "two"),
        (
            MaterialRaw::Diffuse {
                albedo: Rgb::new(0.2, 0.4, 0.6).into()
            },
            false
        )
    );
    assert_eq!(
        material(&i, "mirror"),
        (
            MaterialRaw::Mirror {
                reflectance: Rgb::WHITE.into()
            },
            true
        )
    );
    // Mitsuba 3.9.1's RGB gold.
    let MaterialRaw::Conductor { eta, k } = material(&i, "gold").0 else {
        panic!()
    };
    assert!(
        (eta.r - 0.143036).abs() < 1e-6 && (k.b - 1.60336).abs() < 1e-6,
        "{eta:?} {k:?}"
    );
    assert_eq!(
        material(&i, "custom").0,
        MaterialRaw::Conductor {
            eta: Rgb::new(1.0, 2.0, 3.0),
            k: Rgb::splat(0.5)
        }
    );
    let MaterialRaw::RoughConductor { roughness, .. } = material(&i, "rough").0 else {
        panic!()
    };
    assert_eq!(roughness, Roughness::Isotropic(0.1));
    let (water, sided) = material(&i, "water");
    assert!(!sided);
    let MaterialRaw::Dielectric { ior } = water else {
        panic!()
    };
    assert!((ior - 1.333 / 1.000277).abs() < 1e-5, "{ior}");
    assert_eq!(
        material(&i, "pane"),
        (MaterialRaw::ThinDielectric { ior: 1.333 }, false)
    );
    assert_eq!(
        material(&i, "inside").0,
        MaterialRaw::Dielectric { ior: 1.0 / 1.5 }
    );
    // Mitsuba's defaults: int_ior bk7 (1.5046), ext_ior air (1.000277).
    let MaterialRaw::RoughDielectric {
        roughness,
        ior,
        distribution,
    } = material(&i, "frosted").0
    else {
        panic!()
    };
    assert_eq!(roughness, Roughness::Isotropic(0.2));
    assert_eq!(distribution, Microfacets::Ggx);
    assert!((ior - 1.5046 / 1.000277).abs() < 1e-5, "{ior}");
    // Mitsuba's rough defaults: Beckmann, α = 0.1, and the material "none" (η = 0, k = 1).
    assert_eq!(
        material(&i, "default-rough").0,
        MaterialRaw::RoughConductor {
            roughness: Roughness::Isotropic(0.1),
            eta: Rgb::BLACK,
            k: Rgb::WHITE,
            distribution: Microfacets::Beckmann
        }
    );
    let (_, _, m) = err(
        "bad-albedo",
        &format!("{SENSOR}<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"1.5\"/></bsdf>"),
    );
    assert!(m.contains("[0, 1]"), "{m}");
    // A malformed number for an IOR is reported as such, not as a missing <string>.
    let (_, _, m) = err(
        "bad-ior",
        &format!(
            "{SENSOR}<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"1,5\"/></bsdf>"
        ),
    );
    assert!(
        m.contains("'int_ior' = '1,5' is not a finite number"),
        "{m}"
    );
    // alpha_u along ∂p/∂u, alpha_v across it.
    let i = ok(
        "anisotropic",
        &format!(
            "{SENSOR}<bsdf type=\"roughconductor\" id=\"a\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.3\"/></bsdf>"
        ),
    );
    let MaterialRaw::RoughConductor { roughness, .. } = material(&i, "a").0 else {
        panic!()
    };
    assert_eq!(roughness, Roughness::Anisotropic(0.1, 0.3));
    let (_, _, m) = err(
        "half-anisotropic",
        &format!(
            "{SENSOR}<bsdf type=\"roughconductor\"><float name=\"alpha_u\" value=\"0.1\"/></bsdf>"
        ),
    );
    assert!(m.contains("given together"), "{m}");
    let (_, _, m) = err(
        "bad-preset",
        &format!(
            "{SENSOR}<bsdf type=\"conductor\"><string name=\"material\" value=\"Unobtainium\"/></bsdf>"
        ),
    );
    assert!(m.contains("Au") && m.contains("Unobtainium"), "{m}");
}

#[test]
fn emitters_become_lights() {
    let i = ok(
        "emitters",
        &format!(
            r#"{SENSOR}
            <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter></shape>
            <shape type="sphere"/>
            <emitter type="point"><point name="position" x="1" y="2" z="3"/><rgb name="intensity" value="5"/></emitter>
            <emitter type="point"><transform name="to_world"><translate x="-1"/></transform></emitter>
            <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
            <emitter type="spot"><rgb name="intensity" value="3"/><float name="cutoff_angle" value="40"/>
                <transform name="to_world"><lookat origin="1, 2, 3" target="1, 0, 3" up="1, 0, 0"/></transform></emitter>
            <emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="2"/>
                <transform name="to_world"><rotate y="1" angle="90"/></transform></emitter>
            <emitter type="directional"><vector name="direction" value="0, -2, 0"/><rgb name="irradiance" value="4"/></emitter>
            <emitter type="directional"><transform name="to_world"><lookat origin="0, 0, 0" target="1, 0, 0" up="0, 1, 0"/></transform></emitter>"#
        ),
    );
    // A missing image is reported at the element naming it (it was reported at line 1, column 1
    // when the scene was built).
    let (line, _, m) = err(
        "missing-envmap",
        &format!(
            "{SENSOR}\n<emitter type=\"envmap\"><string name=\"filename\" value=\"missing.exr\"/></emitter>"
        ),
    );
    assert!(
        line == 5 && m.contains("missing.exr does not exist"),
        "{line}: {m}"
    );
    let e = i.desc.shapes[0].emission.unwrap();
    assert_eq!(e.radiance, Rgb::new(1.0, 2.0, 3.0));
    assert!(!e.two_sided);
    assert!(i.desc.shapes[1].emission.is_none());
    // A shape without a BSDF gets Mitsuba's default: diffuse 0.5, one-sided.
    assert_eq!(
        material(&i, &i.desc.shapes[1].material),
        (
            MaterialRaw::Diffuse {
                albedo: Rgb::splat(0.5).into()
            },
            true
        )
    );
    let lights: Vec<LightRaw> = i.desc.lights.iter().map(|l| l.0.clone()).collect();
    assert!(matches!(lights[0], LightRaw::Point { position, intensity }
        if close(position, DVec3::new(1.0, 2.0, 3.0)) && intensity == Rgb::splat(5.0)));
    assert!(matches!(lights[1], LightRaw::Point { position, intensity }
        if close(position, DVec3::new(-1.0, 0.0, 0.0)) && intensity == Rgb::WHITE));
    assert!(matches!(lights[2], LightRaw::Environment { radiance } if radiance == Rgb::splat(0.5)));
    // Mitsuba's spot: to_world's origin, its +z, beam_width 3/4 of the cutoff, linear in angle.
    let LightRaw::Spot {
        position,
        target,
        intensity,
        cone_angle,
        falloff_start,
        profile,
    } = lights[3]
    else {
        panic!("{:?}", lights[3])
    };
    assert!(close(position, DVec3::new(1.0, 2.0, 3.0)) && close(target, DVec3::new(1.0, 1.0, 3.0)));
    assert_eq!(
        (intensity, cone_angle, falloff_start),
        (Rgb::splat(3.0), 40.0, Some(30.0))
    );
    assert_eq!(profile, lightlab_scene::SpotProfile::Angular);
    // A beam wider than the cutoff is refused in Mitsuba's own names.
    let (_, _, m) = err(
        "wide-beam",
        &format!(
            r#"{SENSOR}<emitter type="spot"><float name="cutoff_angle" value="10"/>
            <float name="beam_width" value="20"/></emitter>"#
        ),
    );
    assert!(
        m.contains("beam_width must be in (0, cutoff_angle = 10]") && !m.contains("falloff_start"),
        "{m}"
    );
    let LightRaw::EnvironmentMap {
        file,
        scale,
        rotate,
    } = &lights[4]
    else {
        panic!("{:?}", lights[4])
    };
    assert_eq!((file.as_str(), *scale), ("sky.exr", 2.0));
    assert!(rotate.len() == 1 && (rotate[0].axis - glam::Vec3::Y).length() < 1e-6);
    assert!((rotate[0].degrees - 90.0).abs() < 1e-4, "{rotate:?}");
    // Mitsuba's directional light travels along `direction`, or to_world's +z; irradiance default 1.
    assert!(
        matches!(lights[5], LightRaw::Directional { direction, irradiance }
        if close(direction, DVec3::new(0.0, -2.0, 0.0)) && irradiance == Rgb::splat(4.0))
    );
    assert!(
        matches!(lights[6], LightRaw::Directional { direction, irradiance }
        if close(direction, DVec3::X) && irradiance == Rgb::WHITE)
    );
    let (_, _, m) = err(
        "envmap-scaled",
        &format!(
            "{SENSOR}<emitter type=\"envmap\"><string name=\"filename\" value=\"a.exr\"/><transform name=\"to_world\"><scale value=\"2\"/></transform></emitter>"
        ),
    );
    assert!(m.contains("rotation"), "{m}");
    // An area emitter above the 10¹⁵ cap every other light has (it rendered black with light
    // tracing, 10× too dark with BDPT and NaN with radiosity), located at its <emitter>.
    let (line, _, m) = err(
        "area-too-bright",
        &format!(
            r#"{SENSOR}
<shape type="sphere">
<emitter type="area"><rgb name="radiance" value="3e38"/></emitter></shape>"#
        ),
    );
    assert!(m.contains("at most 1e15") && line > 1, "{line}: {m}");
}

/// The scene files from Mitsuba's tutorials (`../shared/mitsuba-scenes/`, beside the checkout)
/// import and build; skipped with a message where that folder is absent.
#[test]
fn shared_tutorial_scenes_import() {
    let shared = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/mitsuba-scenes");
    if !shared.is_dir() {
        eprintln!("skipped: {} is not here", shared.display());
        return;
    }
    let cbox = import(&shared.join("cbox.xml"), &[("res".into(), "64".into())]).unwrap();
    assert_eq!(cbox.desc.camera.resolution, (64, 64));
    assert_eq!(cbox.spp, Some(128));
    assert_eq!(cbox.desc.shapes.len(), 8);
    assert!(cbox.notes.iter().any(|n| n.contains("tent")));
    let scene = lightlab_scene::build_scene(cbox.desc, &shared.join("cbox.xml")).unwrap();
    assert_eq!(scene.lights.len(), 1);
    let simple = import(&shared.join("simple.xml"), &[]).unwrap();
    assert_eq!(simple.desc.lights.len(), 2);
    assert_eq!(
        simple.integrator.unwrap().unwrap(),
        "Path(max_bounces: Some(1))"
    );
    lightlab_scene::build_scene(simple.desc, &shared.join("simple.xml")).unwrap();
}

/// A disk is a fan of triangles with the disk's exact area, facing the transformed +z, within
/// 4·10⁻⁶ of the radius everywhere on its rim, and the import says so.
#[test]
fn disks_keep_their_area_and_orientation() {
    let i = ok(
        "disk",
        &format!(
            r#"{SENSOR}<shape type="disk"><transform name="to_world"><scale value="2"/>
            <rotate x="1" angle="90"/><translate y="1"/></transform></shape>"#
        ),
    );
    let GeometryRaw::Mesh {
        positions, indices, ..
    } = &i.desc.shapes[0].geometry.0
    else {
        panic!()
    };
    let centre = DVec3::new(0.0, 1.0, 0.0);
    // +90° about x takes +z to −y.
    let mut area = 0.0;
    for [a, b, c] in triangles(positions, indices) {
        let n = (b - a).cross(c - a);
        assert!(n.normalize().dot(DVec3::NEG_Y) > 0.999_999, "{n}");
        area += 0.5 * n.length();
        let mid = (b + c) / 2.0;
        for p in [b, mid] {
            assert!(((p - centre).length() - 2.0).abs() < 1e-5, "{p}");
        }
    }
    assert!(
        (area / (4.0 * std::f64::consts::PI) - 1.0).abs() < 1e-12,
        "{area}"
    );
    assert!(i.notes.iter().any(|n| n.contains("disk")), "{:?}", i.notes);
}
