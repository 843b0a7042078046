//! Mitsuba 3 XML scenes, imported into Lightlab's scene description ([`SceneDesc`]).
//!
//! The file is read with `roxmltree` (every element keeps its file, line and column, so errors are
//! located), `<include>`s are spliced in, `<default>` parameters are substituted for `$name` (the
//! command line's `-D name=value` wins, as in Mitsuba), and `<ref id>`s are resolved. Each plugin
//! reads its parameters through [`object::Object`], which reports any parameter nobody read:
//! unsupported features are errors, never silent substitutions. What the import approximates is
//! returned as notes (printed as warnings) and listed in scenes/README.md, "Mitsuba scenes".
//!
//! Conventions mapped: Mitsuba's `max_depth` counts path segments, Lightlab's `max_bounces`
//! scattering vertices (`max_depth` m ⇒ `max_bounces` m − 1, −1 ⇒ unlimited); `fov` along
//! `fov_axis` becomes the fov along the smaller image axis; reflecting BSDFs are one-sided unless
//! wrapped in `twosided`; area lights emit on the front side only.

mod bsdfs;
mod emitters;
mod object;
mod presets;
mod sensor;
mod shapes;
mod textures;
mod xml;

use crate::SceneError;
use crate::desc::{MaterialDesc, MaterialRaw, SceneDesc, ShapeDesc};
use lightlab_core::Rgb;
use object::Object;
use std::collections::HashMap;
use std::path::Path;
use xml::Element;

/// A Mitsuba scene as Lightlab reads it, with the rendering settings the file asks for.
#[derive(Debug)]
pub struct Imported {
    pub desc: SceneDesc,
    /// The sensor's `sample_count`, if the file has a sampler.
    pub spp: Option<u32>,
    /// The file's `<integrator>` as a Lightlab integrator in RON (e.g. `Path(max_bounces:
    /// Some(5), russian_roulette: Some(5), roulette_threshold: 1.0)`), if it has one; an error for one Lightlab does not
    /// import (fatal only when no integrator is chosen on the command line).
    pub integrator: Option<Result<String, SceneError>>,
    /// What the import approximates, one sentence each, with the file and line.
    pub notes: Vec<String>,
}

/// Whether `path` names a Mitsuba scene (extension `.xml`) rather than a RON one.
pub fn is_mitsuba(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

/// Reads the Mitsuba 3 scene in `path`; `defines` are the command line's `-D name=value`.
/// Checks that `file` (relative to `base`, the scene's directory) exists, so that a missing image
/// is reported at the element that names it rather than when the scene is built.
fn existing(o: &Object, base: &Path, file: &str) -> Result<(), SceneError> {
    let path = base.join(file);
    if path.is_file() {
        Ok(())
    } else {
        Err(o.error(format!("file {} does not exist", path.display())))
    }
}

pub fn import(path: &Path, defines: &[(String, String)]) -> Result<Imported, SceneError> {
    let mut params = xml::Params::new(defines);
    let elements = xml::read_scene(path, &mut params)?;
    params.check_used(path)?;
    let refs = Refs::new(&elements)?;
    let base = path.parent().unwrap_or(Path::new("."));

    let mut materials = Materials::default();
    let mut textures = textures::Textures {
        once: Once::default(),
        base: base.to_path_buf(),
    };
    let mut shapes = Vec::new();
    let mut lights = Vec::new();
    let mut sensor = None;
    let mut integrator = None;
    let mut notes = Vec::new();
    for el in &elements {
        match el.tag.as_str() {
            "integrator" => {
                if integrator.is_some() {
                    return Err(el.at.error("a scene has one <integrator>"));
                }
                integrator = Some(integrator_ron(el));
            }
            "sensor" => {
                if sensor.is_some() {
                    return Err(el.at.error(
                        "a second <sensor>: Lightlab renders one camera per scene; keep one",
                    ));
                }
                sensor = Some(sensor::sensor(el)?);
            }
            "bsdf" => {
                materials.add(el, &refs, &mut textures)?;
            }
            "texture" => {
                textures.add(el)?;
            }
            "shape" => {
                let o = Object::new(el)?;
                let bsdf = o.nested(&["bsdf", "ref"]);
                let emitter = o.nested(&["emitter"]);
                let (geometry, transform) = shapes::geometry(&o, base, &mut notes)?;
                o.finish()?;
                if o.ty == "disk" {
                    notes.push(format!(
                        "{}:{}: the disk is {} triangles with its exact area (Lightlab has no \
                         analytic disk): its rim is within 4·10⁻⁶ of the radius",
                        el.at.file.display(),
                        el.at.line,
                        shapes::DISK_SEGMENTS
                    ));
                }
                let material = match bsdf[..] {
                    [] => materials.default_diffuse(),
                    [b] => materials.add(refs.resolve(b, "bsdf")?, &refs, &mut textures)?,
                    _ => return Err(o.error(format!("{} has more than one BSDF", o.describe()))),
                };
                let emission = match emitter[..] {
                    [] => None,
                    [e] => Some(emitters::area(e)?),
                    _ => return Err(o.error(format!("{} has more than one emitter", o.describe()))),
                };
                if emission.is_some() && geometry.local_area() == Some(0.0) {
                    return Err(o.error("an area light needs a shape with area"));
                }
                shapes.push(ShapeDesc {
                    geometry,
                    material,
                    emission,
                    transform,
                    motion: None,
                });
            }
            "emitter" => lights.push(emitters::light(el, base)?),
            "medium" | "volume" | "phase" => {
                return Err(el.at.error(format!(
                    "<{}> is not imported (see scenes/README.md, \"Mitsuba scenes\")",
                    el.tag
                )));
            }
            other => {
                return Err(el.at.error(format!(
                    "<{other}> is not a Mitsuba scene element (integrator, sensor, bsdf, shape, \
                     emitter, …)"
                )));
            }
        }
    }
    let sensor = sensor.ok_or_else(|| SceneError::Invalid {
        path: path.to_path_buf(),
        line: 1,
        col: 1,
        message: "the scene has no <sensor>: Lightlab needs its camera".into(),
    })?;
    notes.extend(sensor.notes);
    Ok(Imported {
        desc: SceneDesc {
            camera: sensor.camera,
            materials: materials.0.list,
            textures: textures.once.list,
            shapes,
            lights,
        },
        spp: sensor.spp,
        integrator,
        notes,
    })
}

/// Elements with an `id`, for `<ref id>`.
pub(crate) struct Refs<'a> {
    ids: HashMap<&'a str, &'a Element>,
}

impl<'a> Refs<'a> {
    fn new(elements: &'a [Element]) -> Result<Refs<'a>, SceneError> {
        fn visit<'a>(
            el: &'a Element,
            ids: &mut HashMap<&'a str, &'a Element>,
        ) -> Result<(), SceneError> {
            if el.tag != "ref"
                && let Some(id) = el.attr("id")
                && ids.insert(id, el).is_some()
            {
                return Err(el.at.error(format!("id \"{id}\" is used twice")));
            }
            el.children.iter().try_for_each(|c| visit(c, ids))
        }
        let mut ids = HashMap::new();
        elements.iter().try_for_each(|e| visit(e, &mut ids))?;
        Ok(Refs { ids })
    }

    /// `el` itself, or the `tag` element a `<ref id>` names.
    pub fn resolve(&self, el: &'a Element, tag: &str) -> Result<&'a Element, SceneError> {
        if el.tag != "ref" {
            return Ok(el);
        }
        el.only_attrs(&["id", "name"])?;
        let id = el.require("id")?;
        match self.ids.get(id) {
            Some(target) if target.tag == tag => Ok(target),
            Some(target) => Err(el.at.error(format!(
                "<ref id=\"{id}\"> names a <{}>, but a <{tag}> is expected here",
                target.tag
            ))),
            None => Err(el
                .at
                .error(format!("<ref id=\"{id}\">: no element has this id"))),
        }
    }
}

/// Plugins (BSDFs, textures) in the order first met, each element imported once however often it
/// is referenced, named by its `id` (or its type and place in the file).
pub(crate) struct Once<T> {
    pub list: Vec<(String, T)>,
    /// Element address → name.
    seen: HashMap<usize, String>,
}

impl<T> Default for Once<T> {
    fn default() -> Self {
        Once {
            list: Vec::new(),
            seen: HashMap::new(),
        }
    }
}

impl<T> Once<T> {
    /// The name of `el` (a `<kind>`), imported by `import` on first use.
    pub fn add(
        &mut self,
        el: &Element,
        kind: &str,
        import: impl FnOnce() -> Result<T, SceneError>,
    ) -> Result<String, SceneError> {
        let key = el as *const Element as usize;
        if let Some(name) = self.seen.get(&key) {
            return Ok(name.clone());
        }
        let value = import()?;
        let name = match el.attr("id") {
            Some(id) => id.to_string(),
            None => format!(
                "{} {kind} at {}:{}",
                el.attr("type").unwrap_or("?"),
                el.at.file.display(),
                el.at.line
            ),
        };
        self.list.push((name.clone(), value));
        self.seen.insert(key, name.clone());
        Ok(name)
    }
}

/// The scene's materials.
#[derive(Default)]
struct Materials(Once<MaterialDesc>);

impl Materials {
    fn add(
        &mut self,
        el: &Element,
        refs: &Refs,
        textures: &mut textures::Textures,
    ) -> Result<String, SceneError> {
        self.0
            .add(el, "bsdf", || bsdfs::material(el, refs, textures))
    }

    /// Mitsuba's BSDF for a shape without one: diffuse, reflectance 0.5, one-sided.
    fn default_diffuse(&mut self) -> String {
        let name = "default diffuse (Mitsuba's default BSDF)";
        if !self.0.list.iter().any(|(n, _)| n == name) {
            let raw = MaterialRaw::Diffuse {
                albedo: Rgb::splat(0.5).into(),
            };
            self.0.list.push((
                name.to_string(),
                MaterialDesc {
                    raw,
                    one_sided: true,
                },
            ));
        }
        name.to_string()
    }
}

/// The file's integrator as Lightlab settings in RON.
fn integrator_ron(el: &Element) -> Result<String, SceneError> {
    let o = Object::new(el)?;
    if o.boolean("hide_emitters", false)? {
        return Err(o.error("hide_emitters is not imported: Lightlab always shows emitters"));
    }
    let bounces = |o: &Object| -> Result<String, SceneError> {
        let max_depth = o.integer("max_depth")?.unwrap_or(-1);
        let rr = o.integer("rr_depth")?.unwrap_or(5);
        if rr < 1 {
            return Err(o.error(format!("rr_depth must be ≥ 1, got {rr}")));
        }
        let max = match max_depth {
            -1 => "None".to_string(),
            m if (1..=u32::MAX as i64).contains(&m) => format!("Some({})", m - 1),
            m => {
                return Err(o.error(format!(
                    "max_depth must be −1 (unlimited) or 1…{} (1 = emitters seen directly), got {m}",
                    u32::MAX
                )));
            }
        };
        if rr > u32::MAX as i64 {
            return Err(o.error(format!("rr_depth must be at most {}, got {rr}", u32::MAX)));
        }
        // Mitsuba plays roulette on every path from rr_depth on, survival in proportion to
        // throughput (capped at 0.95 there; not here): Lightlab's threshold 1.
        Ok(format!(
            "max_bounces: {max}, russian_roulette: Some({rr}), roulette_threshold: 1.0"
        ))
    };
    let ron = match o.ty {
        // Without media, Mitsuba's volumetric path tracers are its path tracer.
        "path" | "volpath" | "volpathmis" => format!("Path({})", bounces(&o)?),
        "direct" => {
            for k in ["emitter_samples", "bsdf_samples", "shading_samples"] {
                if o.integer(k)?.is_some_and(|n| n != 1) {
                    return Err(o.error(format!(
                        "direct with {k} ≠ 1 is not imported (Lightlab takes one light and one \
                         BSDF sample per path vertex)"
                    )));
                }
            }
            "Path(max_bounces: Some(1))".to_string()
        }
        "bdpt" => format!("Bdpt({})", bounces(&o)?),
        "ptracer" => {
            o.integer("samples_per_pass")?;
            format!("Light({})", bounces(&o)?)
        }
        other => {
            return Err(o.error(format!(
                "integrator type '{other}' is not imported (supported: path, volpath, \
                 volpathmis, direct, bdpt, ptracer); choose Lightlab's with --integrator"
            )));
        }
    };
    o.finish()?;
    Ok(ron)
}
