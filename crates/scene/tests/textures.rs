//! Textures in scene files: Mitsuba's `bitmap` and `checkerboard` imported parameter by parameter,
//! each Mitsuba shape's texture coordinates at a hit equal to Mitsuba 3.9.1's (values read off its
//! `ray_intersect`), and RON's texture errors. Deterministic.

use glam::{Vec2, Vec3};
use lightlab_core::{Ray, Rgb};
use lightlab_scene::desc::{ColourDesc, FilterDesc, MaterialRaw, TextureDesc, WrapDesc};
use lightlab_scene::mitsuba::{Imported, import};
use lightlab_scene::{Scene, SceneError, build_scene, parse_scene};
use std::path::{Path, PathBuf};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("lightlab-textures-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
        <rfilter type="box"/></film></sensor>"#;

/// Imports `body` (inside `<scene>`, after a sensor) as `d`/scene.xml.
fn import_body(d: &Path, body: &str) -> Result<Imported, SceneError> {
    let path = d.join("scene.xml");
    std::fs::write(
        &path,
        format!("<scene version=\"3.0.0\">{SENSOR}\n{body}\n</scene>\n"),
    )
    .unwrap();
    import(&path, &[])
}

fn message(r: Result<Imported, SceneError>) -> String {
    match r {
        Err(SceneError::Invalid { message, .. }) => message,
        Err(e) => panic!("not a located error: {e}"),
        Ok(_) => panic!("imported, but an error was expected"),
    }
}

/// A 2 × 2 PNG next to the scene.
fn write_png(d: &Path) {
    image::RgbImage::from_fn(2, 2, |x, y| image::Rgb([60 * x as u8, 90 * y as u8, 200]))
        .save(d.join("t.png"))
        .unwrap();
}

#[test]
fn bitmap_and_checkerboard_parameters() {
    let d = dir("params");
    write_png(&d);
    let i = import_body(
        &d,
        r#"<texture type="bitmap" id="shared"><string name="filename" value="t.png"/>
            <string name="filter_type" value="nearest"/><string name="wrap_mode" value="mirror"/>
            <boolean name="raw" value="true"/><string name="format" value="variant"/>
            <boolean name="accel" value="false"/>
            <transform name="to_uv"><scale x="2" y="3"/><translate x="0.5" y="-1"/></transform></texture>
        <bsdf type="diffuse" id="a"><ref name="reflectance" id="shared"/></bsdf>
        <bsdf type="twosided" id="b"><bsdf type="diffuse"><ref name="reflectance" id="shared"/></bsdf></bsdf>
        <bsdf type="diffuse" id="c"><texture type="checkerboard" name="reflectance"/></bsdf>
        <bsdf type="conductor" id="m"><texture type="checkerboard" name="specular_reflectance">
            <rgb name="color0" value="0.9"/><rgb name="color1" value="0.1, 0.2, 0.3"/>
            <transform name="to_uv"><rotate z="1" angle="90"/></transform></texture></bsdf>
        <shape type="rectangle"><ref id="a"/></shape>"#,
    )
    .unwrap();
    let textures = &i.desc.textures;
    assert_eq!(
        textures.len(),
        3,
        "the shared texture is imported once: {textures:?}"
    );
    assert_eq!(
        textures[0],
        (
            "shared".to_string(),
            TextureDesc::Bitmap {
                file: "t.png".into(),
                filter: FilterDesc::Nearest,
                wrap: WrapDesc::Mirror,
                raw: true,
                scale: (1.0, 1.0),
                offset: (0.0, 0.0),
                to_uv: Some([[2.0, 0.0, 0.5], [0.0, 3.0, -1.0]]),
            }
        )
    );
    let colour = |name: &str| match &i
        .desc
        .materials
        .iter()
        .find(|(n, _)| n == name)
        .unwrap()
        .1
        .raw
    {
        MaterialRaw::Diffuse { albedo } => albedo.clone(),
        MaterialRaw::Mirror { reflectance } => reflectance.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!(colour("a"), ColourDesc::Texture("shared".into()));
    assert_eq!(colour("b"), ColourDesc::Texture("shared".into()));
    // Mitsuba's checkerboard defaults: 0.4 and 0.2 grey.
    let ColourDesc::Texture(c) = colour("c") else {
        panic!()
    };
    let (_, t) = textures.iter().find(|(n, _)| *n == c).unwrap();
    assert!(
        matches!(t, TextureDesc::Checkerboard { color0, color1, to_uv: None, .. }
        if *color0 == Rgb::splat(0.4) && *color1 == Rgb::splat(0.2))
    );
    let ColourDesc::Texture(m) = colour("m") else {
        panic!()
    };
    let (_, t) = textures.iter().find(|(n, _)| *n == m).unwrap();
    let TextureDesc::Checkerboard {
        to_uv: Some(rows), ..
    } = t
    else {
        panic!("{t:?}")
    };
    // A 90° turn about z: u′ = −v, v′ = u.
    let want = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0]];
    for (r, w) in rows.iter().flatten().zip(want.iter().flatten()) {
        assert!((r - w).abs() < 1e-6, "{rows:?}");
    }
    // The scene builds: the image is read and the lookups resolve.
    let sc = build_scene(i.desc, &d.join("scene.xml")).unwrap();
    assert_eq!(sc.textures.len(), 3);
}

#[test]
fn texture_errors_are_located_and_say_what_is_supported() {
    let d = dir("errors");
    write_png(&d);
    for (body, expect) in [
        (
            r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="t.png"/>
                <string name="filter_type" value="cubic"/></texture></bsdf>"#,
            "filter_type \"cubic\"",
        ),
        (
            r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"/></bsdf>"#,
            "needs a filename",
        ),
        (
            r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="t.png"/>
                <float name="gamma" value="2"/></texture></bsdf>"#,
            "parameter 'gamma'",
        ),
        (
            r#"<bsdf type="diffuse"><texture type="noise" name="reflectance"/></bsdf>"#,
            "texture type 'noise'",
        ),
        (
            r#"<bsdf type="diffuse"><ref name="reflectance" id="nowhere"/></bsdf>"#,
            "no element has this id",
        ),
    ] {
        let m = message(import_body(&d, body));
        assert!(m.contains(expect), "{m}");
    }
}

/// The (u, v) at the first hit of a ray given in the file's coordinates.
fn uv_at(sc: &Scene, o: Vec3, d: Vec3) -> Vec2 {
    let o = (o.as_dvec3() - sc.origin).as_vec3();
    sc.intersect(&Ray::new(o, d)).expect("the ray hits").uv
}

/// One shape per scene, with Mitsuba 3.9.1's (u, v) for the same rays.
#[test]
fn shapes_have_mitsubas_texture_coordinates() {
    let d = dir("uvs");
    std::fs::write(
        d.join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n",
    )
    .unwrap();
    std::fs::write(
        d.join("tri.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         property float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\n\
         end_header\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\n3 0 1 2\n",
    )
    .unwrap();
    let down = -Vec3::Z;
    let cases: [(&str, Vec3, Vec3, Vec2); 11] = [
        (
            r#"<shape type="rectangle"/>"#,
            Vec3::new(0.5, -0.5, 2.0),
            down,
            Vec2::new(0.75, 0.25),
        ),
        (
            r#"<shape type="rectangle"/>"#,
            Vec3::new(-0.5, 0.5, 2.0),
            down,
            Vec2::new(0.25, 0.75),
        ),
        (
            r#"<shape type="rectangle"><transform name="to_world"><rotate z="1" angle="90"/></transform></shape>"#,
            Vec3::new(0.5, -0.5, 2.0),
            down,
            Vec2::new(0.25, 0.25),
        ),
        (
            r#"<shape type="cube"/>"#,
            Vec3::new(0.2, -3.0, 0.6),
            Vec3::Y,
            Vec2::new(0.8, 0.6),
        ),
        (
            r#"<shape type="cube"/>"#,
            Vec3::new(3.0, 0.2, 0.6),
            -Vec3::X,
            Vec2::new(0.6, 0.2),
        ),
        (
            r#"<shape type="cube"/>"#,
            Vec3::new(0.2, 0.6, 3.0),
            down,
            Vec2::new(0.8, 0.6),
        ),
        (
            r#"<shape type="disk"/>"#,
            Vec3::new(0.3, 0.4, 2.0),
            down,
            Vec2::new(0.5, 0.1476),
        ),
        (
            r#"<shape type="sphere"><transform name="to_world"><rotate x="1" angle="90"/></transform></shape>"#,
            Vec3::new(3.0, 0.3, 0.01),
            -Vec3::X,
            Vec2::new(0.0017, 0.597),
        ),
        (
            r#"<shape type="obj"><string name="filename" value="tri.obj"/></shape>"#,
            Vec3::new(0.2, 0.3, 2.0),
            down,
            Vec2::new(0.2, 0.7),
        ),
        (
            r#"<shape type="obj"><string name="filename" value="tri.obj"/><boolean name="flip_tex_coords" value="false"/></shape>"#,
            Vec3::new(0.2, 0.3, 2.0),
            down,
            Vec2::new(0.2, 0.3),
        ),
        (
            r#"<shape type="ply"><string name="filename" value="tri.ply"/></shape>"#,
            Vec3::new(0.2, 0.3, 2.0),
            down,
            Vec2::new(0.2, 0.3),
        ),
    ];
    for (shape, o, dir_, want) in cases {
        let i = import_body(&d, shape).unwrap();
        let sc = build_scene(i.desc, &d.join("scene.xml")).unwrap();
        let got = uv_at(&sc, o, dir_);
        assert!(
            (got - want).abs().max_element() < 2e-4,
            "{shape}: {got} vs Mitsuba's {want}"
        );
    }
}

fn ron_error(d: &Path, textures: &str, albedo: &str) -> String {
    let text = format!(
        "Scene(camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (8, 8)),
            textures: {{ {textures} }},
            materials: {{ \"m\": Diffuse(albedo: {albedo}) }},
            shapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"m\") ])"
    );
    match parse_scene(&text, &d.join("scene.ron")) {
        Err(SceneError::Invalid { message, line, .. }) => {
            assert!(line >= 1);
            message
        }
        Err(e) => panic!("not a located error: {e}"),
        Ok(_) => panic!("loaded, but an error was expected"),
    }
}

#[test]
fn ron_texture_errors_say_what_is_wrong() {
    let d = dir("ron");
    exr::prelude::write_rgb_file(d.join("bright.exr"), 2, 1, |x, _| {
        (2.0 * x as f32, 0.5, 0.5)
    })
    .unwrap();
    let cases = [
        (
            "",
            "\"wood\"",
            "names texture \"wood\", which is not in `textures`",
        ),
        (
            "\"b\": Bitmap(file: \"bright.exr\")",
            "\"b\"",
            "values must lie in [0, 1]",
        ),
        (
            "\"b\": Bitmap(file: \"missing.png\")",
            "\"b\"",
            "does not exist",
        ),
        (
            "\"c\": Checkerboard(scale: (2, 2), to_uv: ((1, 0, 0), (0, 1, 0)))",
            "\"c\"",
            "either scale/offset or to_uv",
        ),
        (
            "\"c\": Checkerboard(color0: (-1, 0, 0))",
            "\"c\"",
            "Checkerboard color0",
        ),
        (
            "\"c\": Checkerboard(), \"c\": Checkerboard()",
            "\"c\"",
            "defined twice",
        ),
        ("", "(0.5, 0.5)", "tuple of size 3"),
        ("", "0.5", "colour (r, g, b) or the name of a texture"),
    ];
    for (textures, albedo, expect) in cases {
        let m = ron_error(&d, textures, albedo);
        assert!(m.contains(expect), "{textures} / {albedo}: {m}");
    }
}
