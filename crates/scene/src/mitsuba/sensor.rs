//! The `<sensor>` (perspective or thin-lens camera), its `<film>` and `<sampler>`.

use super::object::Object;
use super::xml::Element;
use crate::SceneError;
use crate::desc::{CameraDesc, CameraRaw, Lens};
use glam::{DMat4, DVec3};

/// The camera, the file's sample count, and notes on what the import approximates.
pub(crate) struct Sensor {
    pub camera: CameraDesc,
    pub spp: Option<u32>,
    pub notes: Vec<String>,
}

pub(crate) fn sensor(el: &Element) -> Result<Sensor, SceneError> {
    let o = Object::new(el)?;
    let mut notes = Vec::new();
    for k in ["principal_point_offset_x", "principal_point_offset_y"] {
        if o.float_or(k, 0.0)? != 0.0 {
            return Err(o.error(format!("{k} ≠ 0 (an off-centre image) is not imported")));
        }
    }
    // Lightlab does not clip: geometry nearer than near_clip is visible (Mitsuba hides it).
    let near = o.float_or("near_clip", 0.01)?;
    let far = o.float_or("far_clip", 1e4)?;
    if !(near > 0.0 && far > near) {
        return Err(o.error(format!(
            "near_clip ({near}) and far_clip ({far}) must satisfy 0 < near < far"
        )));
    }
    if o.float("near_clip")?.is_some() || o.float("far_clip")?.is_some() {
        notes.push(format!(
            "{}:{}: near_clip ({near}) and far_clip ({far}) are read but Lightlab does not clip: \
             geometry nearer or farther than them is visible, where Mitsuba hides it",
            el.at.file.display(),
            el.at.line
        ));
    }
    let lens = match o.ty {
        "perspective" => {
            // The pinhole's focus distance only guides Mitsuba's viewer.
            o.float("focus_distance")?;
            Lens::Pinhole
        }
        "thinlens" => Lens::ThinLens {
            aperture_radius: o
                .float("aperture_radius")?
                .ok_or_else(|| o.error("a thinlens sensor needs an aperture_radius"))?
                as f32,
            // Mitsuba's default focus is the far clipping plane.
            focus_distance: o.float_or("focus_distance", far)? as f32,
        },
        other => {
            return Err(o.error(format!(
                "sensor type '{other}' is not imported (supported: perspective, thinlens)"
            )));
        }
    };
    // The field of view: `fov` along `fov_axis`, or a 35 mm film's diagonal for `focal_length`
    // (default 50 mm), as Mitsuba 3 computes it: 2·atan(√(36² + 24²) / (2 f)).
    let (fov, axis) = match (o.float("fov")?, o.string("focal_length")?) {
        (Some(_), Some(_)) => return Err(o.error("give fov or focal_length, not both")),
        (Some(fov), None) => (fov, o.string("fov_axis")?.unwrap_or("x")),
        (None, f) => {
            if o.string("fov_axis")?.is_some() {
                return Err(o.error(
                    "fov_axis applies to fov only (Mitsuba ignores it with focal_length): give fov, \
                     or drop fov_axis",
                ));
            }
            let f = f.unwrap_or("50mm");
            let mm: f64 = f
                .trim()
                .trim_end_matches("mm")
                .parse()
                .ok()
                .filter(|x: &f64| *x > 0.0 && x.is_finite())
                .ok_or_else(|| o.error(format!("focal_length '{f}' is not a length in mm")))?;
            let fov = 2.0 * (36f64.hypot(24.0) / (2.0 * mm)).atan().to_degrees();
            (fov, "diagonal")
        }
    };
    let to_world = o.transform("to_world")?.unwrap_or(DMat4::IDENTITY);

    let mut resolution = (768, 576);
    let mut spp = None;
    let nested = o.nested(&["film", "sampler"]);
    if !nested.iter().any(|c| c.tag == "film") {
        notes.push(format!(
            "{}:{}: the sensor has no film: Mitsuba's default is 768 × 576 with a gaussian \
             reconstruction filter; Lightlab's pixels are box-filtered",
            el.at.file.display(),
            el.at.line
        ));
    }
    for child in nested {
        let c = Object::new(child)?;
        match (child.tag.as_str(), c.ty) {
            ("film", "hdrfilm") => {
                resolution = (size(&c, "width", 768)?, size(&c, "height", 576)?);
                for k in ["pixel_format", "component_format", "file_format"] {
                    c.string(k)?;
                }
                c.boolean("sample_border", false)?;
                for k in [
                    "crop_offset_x",
                    "crop_offset_y",
                    "crop_width",
                    "crop_height",
                ] {
                    if c.integer(k)?.is_some() {
                        return Err(c.error(format!("{k}: cropped films are not imported")));
                    }
                }
                let filter = c.nested(&["rfilter"]);
                let filter = match filter[..] {
                    [] => "gaussian (Mitsuba's default)".to_string(),
                    [f] => f.require("type")?.to_string(),
                    _ => return Err(c.error("a film has one rfilter")),
                };
                if filter != "box" {
                    notes.push(format!(
                        "{}:{}: the film's reconstruction filter is {filter}; Lightlab's pixels \
                         are box-filtered (each sample counts in its own pixel), so edges and \
                         noise differ slightly from Mitsuba's",
                        child.at.file.display(),
                        child.at.line
                    ));
                }
                c.finish()?;
            }
            ("film", other) => {
                return Err(c.error(format!("film type '{other}' is not imported (use hdrfilm)")));
            }
            ("sampler", ty) => {
                let n = c.integer("sample_count")?.unwrap_or(4);
                if n < 1 {
                    return Err(c.error(format!("sample_count must be ≥ 1, got {n}")));
                }
                spp = Some(u32::try_from(n).map_err(|_| c.error("sample_count is too large"))?);
                c.integer("seed")?;
                if ty != "independent" {
                    notes.push(format!(
                        "{}:{}: sampler '{ty}': the sample count is kept, the sampler is the \
                         integrator's own (choose one with its `sampler` setting)",
                        child.at.file.display(),
                        child.at.line
                    ));
                }
                // Stratified and low-discrepancy samplers' own parameters.
                c.boolean("jitter", true)?;
                c.integer("scramble_seed")?;
                c.finish()?;
            }
            _ => unreachable!("nested() returned only films and samplers"),
        }
    }
    // Mitsuba 3's sensor keeps the shutter as shutter_open and shutter_close (default 0); read
    // before `finish`, which refuses whatever was not read.
    let shutter = (
        o.float_or("shutter_open", 0.0)? as f32,
        o.float_or("shutter_close", 0.0)? as f32,
    );
    o.finish()?;

    // Mitsuba's camera looks along +z with +y up and +x to the image's left.
    let eye = to_world.transform_point3(DVec3::ZERO);
    let forward = to_world.transform_vector3(DVec3::Z);
    let up = to_world.transform_vector3(DVec3::Y);
    let left = to_world.transform_vector3(DVec3::X);
    let (lf, lu, ll) = (forward.length(), up.length(), left.length());
    let orthogonal = forward.dot(up).abs() <= 1e-5 * lf * lu
        && forward.dot(left).abs() <= 1e-5 * lf * ll
        && up.dot(left).abs() <= 1e-5 * lu * ll;
    if !orthogonal || (lf - lu).abs() > 1e-5 * lf || (lf - ll).abs() > 1e-5 * lf {
        return Err(o.error(
            "the sensor's to_world must be a rotation and translation (with at most a uniform \
             scale or a mirror)",
        ));
    }
    let mirrored = (-left).dot(forward.cross(up)) < 0.0;

    // Lightlab's fov is along the smaller image axis.
    let (w, h) = (resolution.0 as f64, resolution.1 as f64);
    let extent = match axis {
        "x" => w,
        "y" => h,
        "diagonal" => w.hypot(h),
        "smaller" => w.min(h),
        "larger" => w.max(h),
        other => {
            return Err(o.error(format!(
                "fov_axis '{other}' is not one of x, y, diagonal, smaller, larger"
            )));
        }
    };
    if !(fov > 0.0 && fov < 180.0) {
        return Err(o.error(format!("fov must be in (0, 180) degrees, got {fov}")));
    }
    let t = (fov.to_radians() / 2.0).tan() * w.min(h) / extent;
    let raw = CameraRaw {
        eye,
        target: eye + forward / lf,
        up: (up / lu).as_vec3(),
        fov: (2.0 * t.atan()).to_degrees() as f32,
        resolution,
        lens,
        shutter,
    };
    let mut camera = CameraDesc::try_from(raw).map_err(|e| o.error(e))?;
    camera.mirrored = mirrored;
    Ok(Sensor { camera, spp, notes })
}

fn size(o: &Object, name: &str, default: u32) -> Result<u32, SceneError> {
    match o.integer(name)? {
        None => Ok(default),
        Some(n) if (1..=crate::MAX_RESOLUTION as i64).contains(&n) => Ok(n as u32),
        Some(n) => Err(o.error(format!(
            "film {name} must be 1…{}, got {n}",
            crate::MAX_RESOLUTION
        ))),
    }
}
