//! Mitsuba emitters: `area` (on a shape), `point`, `spot`, `directional`, `constant` and `envmap`.

use super::object::Object;
use super::xml::Element;
use crate::SceneError;
use crate::desc::{EmissionDesc, LightDesc, LightRaw, RotationDesc};
use glam::{DMat3, DMat4, DQuat, DVec3};
use lightlab_core::Rgb;

/// The emission of an `<emitter type="area">` nested in a shape: one-sided, like Mitsuba's.
pub(crate) fn area(el: &Element) -> Result<EmissionDesc, SceneError> {
    let o = Object::new(el)?;
    if o.ty != "area" {
        return Err(o.error(format!(
            "a shape's emitter must be type 'area', not '{}'",
            o.ty
        )));
    }
    let radiance = o.color("radiance")?.unwrap_or(Rgb::WHITE);
    o.finish()?;
    non_negative(&o, "radiance", radiance)?;
    EmissionDesc::new(radiance, false).map_err(|e| o.error(e))
}

/// A top-level `<emitter>`.
pub(crate) fn light(el: &Element, base: &std::path::Path) -> Result<LightDesc, SceneError> {
    let o = Object::new(el)?;
    let raw = match o.ty {
        "point" => {
            let position = match (o.point("position")?, o.transform("to_world")?) {
                (Some(_), Some(_)) => {
                    return Err(o.error("a point light takes position or to_world, not both"));
                }
                (Some(p), None) => p,
                (None, Some(m)) => m.transform_point3(DVec3::ZERO),
                (None, None) => DVec3::ZERO,
            };
            let intensity = o.color("intensity")?.unwrap_or(Rgb::WHITE);
            non_negative(&o, "intensity", intensity)?;
            LightRaw::Point {
                position,
                intensity,
            }
        }
        "constant" => {
            let radiance = o.color("radiance")?.unwrap_or(Rgb::WHITE);
            non_negative(&o, "radiance", radiance)?;
            LightRaw::Environment { radiance }
        }
        "spot" => {
            // Mitsuba's spot sits at to_world's origin and shines along its +z.
            let m = o.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
            let position = m.transform_point3(DVec3::ZERO);
            let axis = m.transform_vector3(DVec3::Z).normalize_or_zero();
            if axis == DVec3::ZERO {
                return Err(o.error("a spot's to_world must not collapse its axis"));
            }
            let intensity = o.color("intensity")?.unwrap_or(Rgb::WHITE);
            non_negative(&o, "intensity", intensity)?;
            let cutoff = o.float_or("cutoff_angle", 20.0)?;
            let beam = o.float_or("beam_width", cutoff * 0.75)?;
            // Checked here in Mitsuba's names (the scene check would name Lightlab's).
            if !(cutoff > 0.0 && cutoff <= 180.0) {
                return Err(o.error(format!(
                    "cutoff_angle must be in (0, 180] degrees, got {cutoff}"
                )));
            }
            if !(beam > 0.0 && beam <= cutoff) {
                return Err(o.error(format!(
                    "beam_width must be in (0, cutoff_angle = {cutoff}] degrees, got {beam}"
                )));
            }
            LightRaw::Spot {
                position,
                target: position + axis,
                intensity,
                cone_angle: cutoff as f32,
                falloff_start: Some(beam as f32),
                profile: crate::SpotProfile::Angular,
            }
        }
        "directional" => {
            // Mitsuba's directional light travels along `direction`, or along to_world's +z.
            let direction = match (o.point("direction")?, o.transform("to_world")?) {
                (Some(_), Some(_)) => {
                    return Err(
                        o.error("a directional light takes direction or to_world, not both")
                    );
                }
                (Some(d), None) => d,
                (None, m) => m.unwrap_or(DMat4::IDENTITY).transform_vector3(DVec3::Z),
            };
            let irradiance = o.color("irradiance")?.unwrap_or(Rgb::WHITE);
            non_negative(&o, "irradiance", irradiance)?;
            LightRaw::Directional {
                direction,
                irradiance,
            }
        }
        "envmap" => {
            let file = o
                .string("filename")?
                .ok_or_else(|| o.error("an envmap needs a filename"))?;
            super::existing(&o, base, file)?;
            let scale = o.float_or("scale", 1.0)?;
            if o.boolean("mis_compensation", false)? {
                return Err(o.error("mis_compensation is not imported"));
            }
            let m = o.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
            let lin = DMat3::from_mat4(m);
            let rigid = (lin.transpose() * lin - DMat3::IDENTITY)
                .to_cols_array()
                .iter()
                .all(|x| x.abs() < 1e-5)
                && lin.determinant() > 0.0;
            if !rigid {
                return Err(o.error("an envmap's to_world must be a rotation"));
            }
            let (axis, angle) = DQuat::from_mat3(&lin).to_axis_angle();
            let rotate = if angle.abs() > 1e-12 {
                vec![RotationDesc {
                    axis: axis.as_vec3(),
                    degrees: angle.to_degrees() as f32,
                }]
            } else {
                Vec::new()
            };
            LightRaw::EnvironmentMap {
                file: file.to_string(),
                scale: scale as f32,
                rotate,
            }
        }
        "area" => {
            return Err(o.error(
                "an area emitter belongs inside the <shape> that emits (Mitsuba's syntax)",
            ));
        }
        other => {
            return Err(o.error(format!(
                "emitter type '{other}' is not imported (supported: area, point, spot, directional, \
                 constant, envmap)"
            )));
        }
    };
    o.finish()?;
    LightDesc::try_from(raw).map_err(|e| o.error(e))
}

fn non_negative(o: &Object, what: &str, c: Rgb) -> Result<(), SceneError> {
    if c.to_array().iter().all(|x| *x >= 0.0 && x.is_finite()) {
        Ok(())
    } else {
        Err(o.error(format!(
            "{}: {what} must be ≥ 0 and finite per channel",
            o.describe()
        )))
    }
}
