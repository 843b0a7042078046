//! Bad scene input gets a clear error naming file, line and column and what is allowed — never a
//! panic, never a silent default.

use lightlab_scene::parse_scene;
use std::path::Path;

const CAMERA: &str =
    "camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (8, 8))";

/// Loads `body` (inserted after the camera) and returns the error message.
fn error_of(body: &str) -> String {
    let text = format!("Scene(\n{CAMERA},\n{body}\n)");
    match parse_scene(&text, Path::new("scenes/bad.ron")) {
        Ok(_) => panic!("accepted bad scene:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Asserts the message names the file and a line:column, the expected line, and the given words.
fn assert_error(body: &str, line: usize, words: &[&str]) {
    let e = error_of(body);
    let prefix = format!("scenes/bad.ron:{line}:");
    assert!(
        e.starts_with(&prefix),
        "expected an error at line {line}, got: {e}"
    );
    let col: String = e[prefix.len()..]
        .chars()
        .take_while(|c| c.is_ascii_digit())
        .collect();
    assert!(!col.is_empty(), "no column in: {e}");
    for w in words {
        assert!(e.contains(w), "expected '{w}' in: {e}");
    }
}

const WHITE: &str = "materials: { \"white\": Diffuse(albedo: (0.5, 0.5, 0.5)) },";
const LIGHT: &str = "lights: [ Point(position: (0, 1, 0), intensity: (1, 1, 1)) ],";

#[test]
fn unknown_field() {
    assert_error(
        &format!(
            "{WHITE}\nshapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), materal: \"white\") ]"
        ),
        4,
        &["materal", "material"],
    );
}

#[test]
fn missing_mesh_file() {
    assert_error(
        &format!(
            "{WHITE}\n\nshapes: [ Shape(geometry: Obj(file: \"meshes/none.obj\"), material: \"white\") ]"
        ),
        5,
        &["none.obj", "does not exist"],
    );
}

#[test]
fn unknown_material_name() {
    assert_error(
        &format!(
            "{WHITE}\nshapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"whte\") ]"
        ),
        4,
        &["unknown material", "whte", "white"],
    );
}

#[test]
fn albedo_out_of_range() {
    assert_error(
        "materials: { \"a\": Diffuse(albedo: (0.5, -0.1, 0.5)) },",
        3,
        &["albedo", "[0, 1]"],
    );
    assert_error(
        "materials: { \"a\": Diffuse(albedo: (0.5, 1.2, 0.5)) },",
        3,
        &["albedo", "[0, 1]"],
    );
    assert_error(
        "materials: { \"a\": Phong(kd: (0.5, 0.5, 0.5), ks: (0.6, 0, 0), exponent: 10) },",
        3,
        &["kd + ks", "≤ 1"],
    );
    assert_error(
        "materials: { \"a\": Plastic(kd: (0.5, 0.5, 0.5), ks: (1.5, 1, 1)) },",
        3,
        &["Plastic ks", "[0, 1]"],
    );
}

#[test]
fn ior_not_positive() {
    assert_error(
        "materials: { \"g\": Dielectric(ior: 0) },",
        3,
        &["ior", "> 0"],
    );
    assert_error(
        "materials: { \"g\": RoughDielectric(roughness: Isotropic(0.1), ior: -1.5) },",
        3,
        &["ior", "> 0"],
    );
    assert_error(
        "materials: { \"g\": RoughDielectric(roughness: Isotropic(0.1), ior: 1) },",
        3,
        &["ior", "differ from 1"],
    );
    assert_error(
        "materials: { \"p\": Plastic(kd: (0.5, 0.5, 0.5), ior: 0) },",
        3,
        &["Plastic ior", "> 0"],
    );
    assert_error(
        "materials: { \"p\": RoughPlastic(kd: (0.5, 0.5, 0.5), roughness: Isotropic(0.2), ior: 1) },",
        3,
        &["RoughPlastic ior", "differ from 1"],
    );
}

#[test]
fn rough_plastic_roughness_is_isotropic() {
    assert_error(
        "materials: { \"p\": RoughPlastic(kd: (0.5, 0.5, 0.5), roughness: Anisotropic(0.1, 0.3)) },",
        3,
        &[
            "RoughPlastic roughness must be Isotropic",
            "Anisotropic(0.1, 0.3)",
        ],
    );
    assert_error(
        "materials: { \"p\": RoughPlastic(kd: (0.5, 0.5, 0.5), roughness: Isotropic(-1)) },",
        3,
        &["roughness α must be ≥ 0"],
    );
}

#[test]
fn zero_area_emitter() {
    assert_error(
        &format!(
            "{WHITE}\nshapes: [ Shape(geometry: Quad(corner: (0, 0, 0), edge1: (1, 0, 0), edge2: (2, 0, 0)), material: \"white\", emission: (radiance: (1, 1, 1))) ]"
        ),
        4,
        &["zero area"],
    );
    // Not emitting, it is allowed (it changes nothing) but said: most likely a typo.
    let text = format!(
        "Scene(\n{CAMERA},\n{WHITE}\n{LIGHT}\nshapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"white\"), Shape(geometry: Quad(corner: (0, 0, 0), edge1: (1, 0, 0), edge2: (2, 0, 0)), material: \"white\") ]\n)"
    );
    let scene = parse_scene(&text, Path::new("scenes/flat.ron")).unwrap();
    assert_eq!(
        scene.warnings,
        ["scenes/flat.ron: shapes [1] have zero area: no ray can hit them"]
    );
}

/// Collapsed triangles inside a mesh that has area, and an OBJ file's unusable normals, load (they
/// change nothing a ray can see) but are said, as a zero-area shape is.
#[test]
fn collapsed_triangles_and_bad_obj_normals_are_said() {
    let text = format!(
        "Scene(\n{CAMERA},\n{WHITE}\n{LIGHT}\nshapes: [ Shape(geometry: Mesh(positions: [(0, 0, 0), (1, 0, 0), (0, 1, 0)], indices: [(0, 1, 2), (0, 0, 1)]), material: \"white\") ]\n)"
    );
    let scene = parse_scene(&text, Path::new("scenes/collapsed.ron")).unwrap();
    assert_eq!(
        scene.warnings,
        [
            "scenes/collapsed.ron: shape 0 has 1 zero-area triangles (repeated or collinear vertices): no ray can hit them"
        ]
    );
    let dir = std::env::temp_dir().join(format!("lightlab-bad-normals-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n",
    )
    .unwrap();
    let scene_path = dir.join("obj.ron");
    std::fs::write(
        &scene_path,
        format!(
            "Scene(\n{CAMERA},\n{WHITE}\n{LIGHT}\nshapes: [ Shape(geometry: Obj(file: \"tri.obj\"), material: \"white\") ]\n)"
        ),
    )
    .unwrap();
    let scene = lightlab_scene::load_scene(&scene_path).unwrap();
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("1 vertex normals are zero or not finite")),
        "{:?}",
        scene.warnings
    );
}

/// A texture's settings error points at the texture's entry, not at the top of the file.
#[test]
fn texture_settings_errors_are_located() {
    assert_error(
        &format!("{WHITE}\n{LIGHT}\ntextures: {{\n \"t\": Checkerboard(scale: (NaN, 1)),\n}},"),
        6,
        &["texture \"t\"", "must be finite"],
    );
}

#[test]
fn nan_in_a_vertex() {
    assert_error(
        &format!(
            "{WHITE}\nshapes: [ Shape(geometry: Mesh(positions: [(0, 0, 0), (1, NaN, 0), (0, 1, 0)], indices: [(0, 1, 2)]), material: \"white\") ]"
        ),
        4,
        &["position 1", "finite"],
    );
}

#[test]
fn empty_scene() {
    assert_error("", 1, &["empty"]);
    assert_error(WHITE, 1, &["empty"]);
}

#[test]
fn directional_light_needs_a_direction() {
    assert_error(
        &format!("{WHITE}\nlights: [ Directional(direction: (0, 0, 0), irradiance: (1, 1, 1)) ]"),
        4,
        &["Directional direction must be non-zero"],
    );
    assert_error(
        &format!("{WHITE}\nlights: [ Directional(direction: (0, -1, 0), irradiance: (-1, 1, 1)) ]"),
        4,
        &["Directional irradiance"],
    );
}

#[test]
fn other_impossible_values() {
    assert_error(
        &format!(
            "{WHITE}\nshapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 0), material: \"white\") ]"
        ),
        4,
        &["radius", "> 0"],
    );
    assert_error(
        &format!(
            "{WHITE}\nshapes: [ Shape(geometry: Mesh(positions: [(0, 0, 0)], indices: [(0, 1, 2)]), material: \"white\") ]"
        ),
        4,
        &["vertex 1"],
    );
    assert_error(
        &format!("{LIGHT}\nmaterials: {{ \"a\": Diffuse(albedo: (1, 1, 1)), \"a\": Mirror() }},"),
        4,
        &["defined twice"],
    );
    assert_error(
        &format!(
            "{LIGHT}\nshapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"a\", transform: (scale: (1, 2, 1))) ]"
        ),
        4,
        &["uniform scale"],
    );
    assert_error(
        "lights: [ Spot(position: (0, 0, 0), target: (0, -1, 0), intensity: (1, 1, 1), cone_angle: 200) ]",
        3,
        &["cone_angle", "(0, 180]"],
    );
    let e = error_of(&format!(
        "{LIGHT} materials: {{ \"a\": Diffuse(albedo: (1, 1, 1)) }}, shapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"a\", emission: (radiance: (-1, 0, 0))) ]"
    ));
    assert!(e.contains("radiance") && e.contains("≥ 0"), "{e}");
    // Lights so bright that squared pixel values (the variance layer) or the lights' summed power
    // overflow 32-bit floats: they rendered black or with an infinite variance, uncounted.
    for light in [
        "Point(position: (0, 1, 0), intensity: (1e37, 1e37, 1e37))",
        "Environment(radiance: (1, 2e15, 1))",
        "Directional(direction: (0, -1, 0), irradiance: (3e38, 0, 0))",
        "Spot(position: (0, 0, 0), target: (0, -1, 0), intensity: (1e16, 1, 1), cone_angle: 30)",
    ] {
        assert_error(
            &format!("lights: [ {light} ]"),
            3,
            &["at most 1e15", "32-bit"],
        );
    }
    let e = error_of(&format!(
        "{LIGHT} materials: {{ \"a\": Diffuse(albedo: (1, 1, 1)) }}, shapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"a\", emission: (radiance: (1e20, 0, 0))) ]"
    ));
    assert!(e.contains("emission radiance must be at most 1e15"), "{e}");
}

/// Material parameters at which f32 loses the material's light without a word: a rough
/// interface within 10⁻⁴ of index matching, a RoughPlastic coating whose 1/η² overflows, a Phong
/// lobe narrower than f32 directions resolve.
#[test]
fn materials_beyond_f32() {
    for (material, words) in [
        (
            "RoughDielectric(roughness: Isotropic(1), ior: 1.0000001)",
            "RoughDielectric ior must differ from 1 by at least 1e-4",
        ),
        (
            "RoughPlastic(kd: (0.5, 0.5, 0.5), roughness: Isotropic(0.1), ior: 0.99999)",
            "RoughPlastic ior must differ from 1",
        ),
        (
            "RoughPlastic(kd: (0.5, 0.5, 0.5), roughness: Isotropic(0.1), ior: 1e-19)",
            "RoughPlastic ior must be ≥ 1e-18",
        ),
        (
            "Phong(kd: (0, 0, 0), ks: (1, 1, 1), exponent: 1e9)",
            "Phong exponent must be in [0, 1e7]",
        ),
    ] {
        let e = error_of(&format!("{LIGHT}\nmaterials: {{ \"m\": {material} }},"));
        assert!(
            e.starts_with("scenes/bad.ron:4:") && e.contains(words),
            "{e}"
        );
    }
}

#[test]
fn bad_camera() {
    let bad = |cam: &str| {
        let text = format!("Scene(\n{cam},\n{LIGHT}\n)");
        parse_scene(&text, Path::new("scenes/bad.ron"))
            .err()
            .map(|e| e.to_string())
            .expect("accepted a bad camera")
    };
    assert!(
        bad("camera: Camera(eye: (0, 0, 3), target: (0, 0, 3), fov: 40, resolution: (8, 8))")
            .contains("coincide")
    );
    assert!(
        bad("camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 180, resolution: (8, 8))")
            .contains("fov")
    );
    assert!(
        bad("camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (0, 8))")
            .contains("resolution")
    );
    // A field's error points at the field, not at the end of `Camera(...)`.
    let e = bad(
        "camera: Camera(\n eye: (0, 0, 3),\n target: (0, 0, 0),\n fov: 190,\n resolution: (8, 8),\n)",
    );
    assert!(e.starts_with("scenes/bad.ron:5:2: camera fov"), "{e}");
    // RON's own "Integer is out of bounds" now says what the field holds.
    let e = bad("camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (-8, 8))");
    assert!(
        e.starts_with("scenes/bad.ron:2:") && e.contains("a whole number ≥ 0"),
        "{e}"
    );
    let e = lightlab_integrators::IntegratorConfig::from_ron("Sppm(photons_per_pass: -5)")
        .unwrap_err()
        .to_string();
    assert!(e.contains("a whole number ≥ 0"), "{e}");
    // Sides beyond 16384 were accepted and overflowed the film's allocation into an abort.
    let e = bad(
        "camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (4294967295, 1))",
    );
    assert!(
        e.contains("1…16384 pixels") && e.contains("4294967295×1"),
        "{e}"
    );
    assert!(bad("camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), up: (0, 0, 1), fov: 40, resolution: (8, 8))").contains("parallel"));
    // An eye beyond f32 was blamed on a shape's vertex ("NaN or infinite coordinate").
    let e =
        bad("camera: Camera(eye: (0, 0, 3e200), target: (0, 0, 0), fov: 40, resolution: (8, 8))");
    assert!(e.contains("camera eye must be finite and within"), "{e}");
    // An up vector is a direction: its length does not matter, however far from 1.
    for up in ["(0, 1e-30, 0)", "(0, 3e38, 3e38)"] {
        let text = format!(
            "Scene(\ncamera: Camera(eye: (0, 0, 3), target: (0, 0, 0), up: {up}, fov: 40, resolution: (8, 8)),\n{LIGHT}\n)"
        );
        let sc = parse_scene(&text, Path::new("scenes/up.ron")).unwrap();
        assert!(
            sc.camera.right.is_finite() && sc.camera.up.is_finite(),
            "{up}"
        );
    }
    // Extremes f32 cannot carry, which rendered wrong without a word: a subnormal field of view
    // (BDPT −5.6 %), a lens whose area underflows (light tracing lost 98 %), a plane of focus
    // farther than any shape can be, and lenses whose rays or area overflow (black images with a
    // count of non-finite samples).
    for (camera, words) in [
        ("fov: 1e-44", "fov must be in [1e-6, 180)"),
        (
            "fov: 40, lens: ThinLens(aperture_radius: 1e20, focus_distance: 1)",
            "aperture_radius must be at most 1e9",
        ),
        (
            "fov: 40, lens: ThinLens(aperture_radius: 0.01, focus_distance: 1e-22)",
            "aperture_radius / focus_distance must be at most 1e12",
        ),
        (
            "fov: 40, lens: ThinLens(aperture_radius: 1e-19, focus_distance: 1)",
            "aperture_radius must be ≥ 1e-15",
        ),
        (
            "fov: 40, lens: ThinLens(aperture_radius: 0.1, focus_distance: 1e30)",
            "focus_distance must be in (0, 1e20]",
        ),
    ] {
        let e = bad(&format!(
            "camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), resolution: (8, 8), {camera})"
        ));
        assert!(
            e.starts_with("scenes/bad.ron:2:") && e.contains(words),
            "{e}"
        );
    }
    let e = bad(
        "camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (8, 8), lens: ThinLens(aperture_radius: 0, focus_distance: 1))",
    );
    assert!(
        e.starts_with("scenes/bad.ron:2:") && e.contains("aperture_radius"),
        "{e}"
    );
}

#[test]
fn shipped_scenes_load() {
    for s in [
        "cornell-box",
        "caustic-sphere",
        "furnace",
        "point-over-plane",
    ] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("..")
            .join("scenes")
            .join(format!("{s}.ron"));
        lightlab_scene::load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    }
}

/// Settings that would silently render something else are refused with the reason: strategies
/// that never sample lights cannot see point or spot lights (nothing hits them), and
/// `shadows: false` only applies to next-event estimation.
#[test]
fn settings_that_cannot_render_the_scene_are_refused() {
    use lightlab_integrators::IntegratorConfig;
    let text = format!(
        "Scene(\n{CAMERA},\n{WHITE}\nshapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"white\") ],\n{LIGHT}\n)"
    );
    let scene = parse_scene(&text, Path::new("point.ron")).unwrap();
    for strategy in ["BsdfOnly", "Uniform"] {
        let integrator = IntegratorConfig::from_ron(&format!("Path(strategy: {strategy})"))
            .unwrap()
            .build()
            .unwrap();
        let e = integrator.check_scene(&scene).unwrap_err();
        assert!(
            e.contains(strategy) && e.contains("point, spot and directional"),
            "{strategy}: {e}"
        );
        let e = IntegratorConfig::from_ron(&format!("Path(strategy: {strategy}, shadows: false)"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("shadows: false") && e.contains(strategy), "{e}");
    }
    for ok in [
        "Path(strategy: Mis)",
        "Path(strategy: LightOnly, shadows: false)",
    ] {
        let integrator = IntegratorConfig::from_ron(ok).unwrap().build().unwrap();
        assert!(integrator.check_scene(&scene).is_ok(), "{ok}");
    }
    // Stratified and Latin hypercube samples are strata of an f32 in [0, 1): past 2²⁴ of them
    // they overlapped and the top one reached 1.0, silently.
    use lightlab_integrators::Budget;
    let many = Budget::Samples((1 << 24) + 1);
    for sampler in ["Stratified", "LatinHypercube"] {
        let integrator = IntegratorConfig::from_ron(&format!("Path(sampler: {sampler})"))
            .unwrap()
            .build()
            .unwrap();
        let e = integrator.check_budget(&many).unwrap_err();
        assert!(e.contains(sampler) && e.contains("16777216"), "{e}");
        assert!(integrator.check_budget(&Budget::Samples(1 << 24)).is_ok());
        assert_eq!(integrator.best_sample_count(u32::MAX), 1 << 24);
    }
    let sobol = IntegratorConfig::from_ron("Path(sampler: Sobol)")
        .unwrap()
        .build()
        .unwrap();
    assert!(sobol.check_budget(&many).is_ok());
    // Replicates: 1 to 4096 of them, and sample counts they divide (in each, the stratified
    // samplers' limit).
    for bad in ["Path(replicates: 0)", "Bdpt(replicates: 4097)"] {
        let e = IntegratorConfig::from_ron(bad).unwrap_err().to_string();
        assert!(
            e.contains("replicates must be 1 (none) to 4096"),
            "{bad}: {e}"
        );
    }
    let e = IntegratorConfig::from_ron("Vcm(replicates: 2)")
        .unwrap_err()
        .to_string();
    assert!(e.contains("replicates need variant: Vc"), "{e}");
    for config in ["Path(sampler: Sobol, replicates: 8)", "Bdpt(replicates: 8)"] {
        let integrator = IntegratorConfig::from_ron(config).unwrap().build().unwrap();
        let e = integrator.check_budget(&Budget::Samples(60)).unwrap_err();
        assert!(
            e.contains("60 samples") && e.contains("multiple of 8, e.g. 56"),
            "{config}: {e}"
        );
        assert!(integrator.check_budget(&Budget::Samples(64)).is_ok());
        assert_eq!(integrator.best_sample_count(63), 56);
        assert_eq!(integrator.best_sample_count(3), 8);
    }
    let strata = IntegratorConfig::from_ron("Path(sampler: Stratified, replicates: 2)")
        .unwrap()
        .build()
        .unwrap();
    assert!(strata.check_budget(&Budget::Samples(1 << 25)).is_ok());
    let e = strata
        .check_budget(&Budget::Samples((1 << 25) + 2))
        .unwrap_err();
    assert!(e.contains("in each replicate"), "{e}");
}

/// Messages are plain: values as the file writes them, not Rust's debug text.
#[test]
fn messages_show_values_as_written() {
    let e = error_of("materials: { \"a\": Diffuse(albedo: (0.5, -0.6, 0.5)) },");
    assert!(
        e.contains("(0.5, -0.6, 0.5)") && !e.contains("Rgb {"),
        "{e}"
    );
    let e = error_of(&format!(
        "{WHITE}\nshapes: [ Shape(geometry: Mesh(positions: [(0, 0, 0), (1, NaN, 0), (0, 1, 0)], indices: [(0, 1, 2)]), material: \"white\") ]"
    ));
    assert!(e.contains("(1, NaN, 0)") && !e.contains("DVec3"), "{e}");
}

/// A truncated file says so; a byte-order mark is accepted.
#[test]
fn truncated_files_and_byte_order_marks() {
    let full = format!("Scene(\n{CAMERA},\n{WHITE}\n{LIGHT}\n)");
    let cut = &full[..full.len() - 30];
    let e = match parse_scene(cut, Path::new("scenes/cut.ron")) {
        Ok(_) => panic!("accepted a truncated scene"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.starts_with("scenes/cut.ron:") && e.contains("unexpected end of file"),
        "{e}"
    );
    assert!(parse_scene(&format!("\u{feff}{full}"), Path::new("bom.ron")).is_ok());
}

/// Mesh files: a directory is not a mesh, and a malformed OBJ line (a vertex, a face, or a face's
/// vertex, texture-coordinate or normal index) is reported with its number.
#[test]
fn mesh_file_errors_name_the_problem() {
    let dir = std::env::temp_dir().join(format!("lightlab-obj-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    let scene_at = |file: &str| {
        format!(
            "Scene(\n{CAMERA},\n{WHITE}\nshapes: [ Shape(geometry: Obj(file: \"{file}\"), material: \"white\") ],\n{LIGHT}\n)"
        )
    };
    let load = |file: &str| match parse_scene(&scene_at(file), &dir.join("s.ron")) {
        Ok(_) => panic!("{file} accepted"),
        Err(e) => e.to_string(),
    };
    let e = load("meshes");
    assert!(
        e.contains("is a directory") && !e.contains("does not exist"),
        "{e}"
    );
    for (name, body, line, words) in [
        (
            "v.obj",
            "v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n",
            3,
            "three numbers",
        ),
        (
            "nan.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nf 1 2 3\n",
            4,
            "a vertex must be finite",
        ),
        (
            "f.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
            4,
            "at least three",
        ),
        (
            "i.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\n# a face\nf 1 2 9\n",
            5,
            "vertex 9",
        ),
        (
            // An index beyond 64 bits was called not an integer.
            "huge.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n",
            4,
            "vertex that does not exist",
        ),
        (
            "n.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n",
            5,
            "normal 2, but the file has 1",
        ),
        (
            "t.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/-2 3/1\n",
            5,
            "texture coordinate that does not exist",
        ),
        (
            "x.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/n\n",
            6,
            "normal index is not an integer",
        ),
        // A byte that is not UTF-8 (`?` written as Latin-1 é below) is located; the error had
        // no position.
        (
            "latin1.obj",
            "v 0 0 0\nv 1 0 0\n# caf?\nv 0 1 0\nf 1 2 3\n",
            3,
            "byte 0xe9 is not UTF-8",
        ),
    ] {
        let bytes: Vec<u8> = match name {
            "latin1.obj" => body
                .bytes()
                .map(|b| if b == b'?' { 0xe9 } else { b })
                .collect(),
            _ => body.as_bytes().to_vec(),
        };
        std::fs::write(dir.join("meshes").join(name), bytes).unwrap();
        let e = load(&format!("meshes/{name}"));
        assert!(
            e.contains(&format!("{name}:{line}:")) && e.contains(words),
            "{name}: {e}"
        );
    }
    // An emissive mesh whose area overflows f32 (vertices at 10²⁰) was said to have zero area:
    // the extent check, which names the shape, now comes first.
    std::fs::write(
        dir.join("meshes").join("huge.obj"),
        "v 0 0 0\nv 1e20 0 0\nv 0 1e20 0\nf 1 2 3\n",
    )
    .unwrap();
    let text = format!(
        "Scene(\n{CAMERA},\n{WHITE}\nshapes: [ Shape(geometry: Obj(file: \"meshes/huge.obj\"), \
         material: \"white\", emission: (radiance: (1, 1, 1))) ],\n)"
    );
    let e = parse_scene(&text, &dir.join("s.ron"))
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.ron:4:")
            && e.contains("shape 0 reaches 5.000e19")
            && !e.contains("zero area"),
        "{e}"
    );
    std::fs::remove_dir_all(dir).ok();
}

/// A scene file (RON or Mitsuba XML) with a byte that is not UTF-8 is refused at that byte's
/// line and column; it was refused with no position.
#[test]
fn scene_bytes_that_are_not_utf8_are_located() {
    let dir = std::env::temp_dir().join(format!("lightlab-latin1-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, text, at) in [
        ("s.ron", "Scene(\n  // caf?\n)", "s.ron:2:9:"),
        (
            "s.xml",
            "<scene version=\"3.0.0\">\n<!-- ?t? -->\n</scene>",
            "s.xml:2:6:",
        ),
    ] {
        let path = dir.join(name);
        let bytes: Vec<u8> = text
            .bytes()
            .map(|b| if b == b'?' { 0xe9 } else { b })
            .collect();
        std::fs::write(&path, bytes).unwrap();
        let e = match lightlab_scene::load_scene(&path) {
            Ok(_) => panic!("{name} accepted"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains(at) && e.contains("byte 0xe9 is not UTF-8"),
            "{name}: {e}"
        );
    }
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn impossible_motion() {
    let shape = |motion: &str| {
        format!(
            "{WHITE}\n{LIGHT}\nshapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"white\",\n motion: {motion}) ]"
        )
    };
    assert_error(
        &shape("Motion(keys: [Key(time: 0)])"),
        6,
        &["at least two keys", "got 1"],
    );
    assert_error(
        &shape("Motion(keys: [Key(time: 1), Key(time: 0.5, translate: (1, 0, 0))])"),
        6,
        &["increase strictly", "1 then 0.5"],
    );
    assert_error(
        &shape(
            "Motion(keys: [Key(time: 0), Key(time: 1, rotate: [(axis: (0, 0, 0), degrees: 5)])])",
        ),
        6,
        &["non-zero axis"],
    );
    assert_error(
        &shape("Motion(keys: [Key(time: 0), Key(time: 1, translat: (1, 0, 0))])"),
        6,
        &["translat", "translate"],
    );
    // Keys too far apart for f32 to interpolate between (3e38 − (−3e38) overflows).
    assert_error(
        &shape("Motion(keys: [Key(time: -3e38), Key(time: 3e38, translate: (1, 0, 0))])"),
        6,
        &["farther apart than f32", "-3", "interpolated"],
    );
    // A motion that carries the shape beyond f32's range while the shutter (here the instant 0)
    // is open.
    assert_error(
        &shape("Motion(keys: [Key(time: -1, translate: (3e38, 0, 0)), Key(time: 1)])"),
        6,
        &["moving shapes reach", "while the shutter is open"],
    );
    // A pivot or translation beyond f32 (kept in f32; it panicked when converted).
    for motion in [
        "Motion(pivot: (1e39, 0, 0), keys: [Key(time: 0), Key(time: 1)])",
        "Motion(keys: [Key(time: 0), Key(time: 1, translate: (0, 1e300, 0))])",
    ] {
        assert_error(&shape(motion), 6, &["within ±3.4", "e3"]);
    }
    // Emitters stay at rest: light sampling and emission use them there.
    assert_error(
        &format!(
            "{WHITE}\nshapes: [ Shape(geometry: Sphere(center: (0, 0, 0), radius: 1), material: \"white\",\n emission: (radiance: (1, 1, 1)), motion: Motion(keys: [Key(time: 0), Key(time: 1)])) ]"
        ),
        5,
        &["emissive shape cannot move"],
    );
}

#[test]
fn impossible_shutter() {
    // Reversed ends; finite ends whose difference overflows (every sample time would be the close).
    for (shutter, words) in [
        ("(1, 0)", "open ≤ close"),
        ("(-3e38, 3e38)", "longer than f32 holds"),
    ] {
        let text = format!(
            "Scene(camera: Camera(eye: (0, 0, 3), target: (0, 0, 0), fov: 40, resolution: (8, 8),\n shutter: {shutter}))"
        );
        let e = parse_scene(&text, Path::new("scenes/bad.ron"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.starts_with("scenes/bad.ron:") && e.contains(words), "{e}");
    }
}
