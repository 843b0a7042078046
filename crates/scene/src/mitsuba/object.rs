//! A Mitsuba plugin instance (`<bsdf type="diffuse">`, `<shape type="obj">`, …) and typed access to
//! its parameters. Every parameter read is marked; [`Object::finish`] reports the first one nobody
//! read, so an unsupported or misspelt parameter is an error, never silently ignored (Mitsuba's own
//! policy).

use super::xml::Element;
use crate::SceneError;
use glam::{DMat3, DMat4, DVec3};
use lightlab_core::Rgb;
use std::cell::RefCell;

const PROPERTY_TAGS: [&str; 9] = [
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];

pub(crate) struct Object<'a> {
    pub el: &'a Element,
    /// The plugin type (`type` attribute).
    pub ty: &'a str,
    used: RefCell<Vec<bool>>,
}

impl<'a> Object<'a> {
    pub fn new(el: &'a Element) -> Result<Object<'a>, SceneError> {
        el.only_attrs(&["type", "id", "name"])?;
        let ty = el.require("type")?;
        let mut names: Vec<&str> = Vec::new();
        for c in &el.children {
            if PROPERTY_TAGS.contains(&c.tag.as_str()) {
                let name = c.require("name")?;
                if names.contains(&name) {
                    return Err(c.at.error(format!(
                        "parameter '{name}' of {} is given twice",
                        describe(el)
                    )));
                }
                names.push(name);
            }
        }
        Ok(Object {
            el,
            ty,
            used: RefCell::new(vec![false; el.children.len()]),
        })
    }

    /// `<bsdf type="diffuse" id="white">`, for messages.
    pub fn describe(&self) -> String {
        describe(self.el)
    }

    pub fn error(&self, message: impl Into<String>) -> SceneError {
        self.el.at.error(message)
    }

    fn property(&self, name: &str) -> Option<&'a Element> {
        let i = self.el.children.iter().position(|c| {
            PROPERTY_TAGS.contains(&c.tag.as_str()) && c.attr("name") == Some(name)
        })?;
        self.used.borrow_mut()[i] = true;
        Some(&self.el.children[i])
    }

    /// The element type (`float`, `string`, …) of parameter `name`, without reading it.
    pub fn tag_of(&self, name: &str) -> Option<&'a str> {
        self.el
            .children
            .iter()
            .find(|c| PROPERTY_TAGS.contains(&c.tag.as_str()) && c.attr("name") == Some(name))
            .map(|c| c.tag.as_str())
    }

    fn typed(&self, name: &str, tags: &[&str]) -> Result<Option<&'a Element>, SceneError> {
        match self.property(name) {
            Some(p) if !tags.contains(&p.tag.as_str()) => Err(p.at.error(format!(
                "parameter '{name}' of {} must be <{}>, not <{}>",
                self.describe(),
                tags.join("> or <"),
                p.tag
            ))),
            p => Ok(p),
        }
    }

    fn value(p: &Element) -> Result<&str, SceneError> {
        p.only_attrs(&["name", "value"])?;
        p.require("value")
    }

    pub fn float(&self, name: &str) -> Result<Option<f64>, SceneError> {
        let Some(p) = self.typed(name, &["float", "integer"])? else {
            return Ok(None);
        };
        let v = Self::value(p)?;
        match v.trim().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(Some(x)),
            _ => Err(p
                .at
                .error(format!("'{name}' = '{v}' is not a finite number"))),
        }
    }

    pub fn float_or(&self, name: &str, default: f64) -> Result<f64, SceneError> {
        Ok(self.float(name)?.unwrap_or(default))
    }

    pub fn integer(&self, name: &str) -> Result<Option<i64>, SceneError> {
        let Some(p) = self.typed(name, &["integer"])? else {
            return Ok(None);
        };
        let v = Self::value(p)?;
        v.trim()
            .parse::<i64>()
            .map(Some)
            .map_err(|_| p.at.error(format!("'{name}' = '{v}' is not an integer")))
    }

    pub fn boolean(&self, name: &str, default: bool) -> Result<bool, SceneError> {
        let Some(p) = self.typed(name, &["boolean"])? else {
            return Ok(default);
        };
        match Self::value(p)?.trim() {
            "true" | "1" => Ok(true),
            "false" | "0" => Ok(false),
            v => Err(p.at.error(format!("'{name}' = '{v}' is not true or false"))),
        }
    }

    pub fn string(&self, name: &str) -> Result<Option<&'a str>, SceneError> {
        match self.typed(name, &["string"])? {
            Some(p) => Self::value(p).map(Some),
            None => Ok(None),
        }
    }

    /// A colour: `<rgb>` (one or three linear values), `<spectrum>` with one value (a flat
    /// spectrum) or `<float>` (grey). A texture bound to the parameter is refused by name.
    pub fn color(&self, name: &str) -> Result<Option<Rgb>, SceneError> {
        let Some(p) = self.typed(name, &["rgb", "spectrum", "float", "integer"])? else {
            if let Some(t) =
                self.el.children.iter().find(|c| {
                    (c.tag == "texture" || c.tag == "ref") && c.attr("name") == Some(name)
                })
            {
                return Err(t.at.error(format!(
                    "a texture for '{name}' of {}: Lightlab textures reflectance colours only \
                     (diffuse reflectance, conductor specular_reflectance); give a constant <rgb>",
                    self.describe()
                )));
            }
            return Ok(None);
        };
        let v = Self::value(p)?;
        if p.tag == "spectrum" && v.contains(':') {
            return Err(p.at.error(format!(
                "'{name}' is a sampled spectrum (wavelength:value pairs); Lightlab renders RGB — \
                 give <rgb name=\"{name}\" value=\"r, g, b\"/>"
            )));
        }
        let n = numbers(v).map_err(|m| p.at.error(format!("'{name}': {m}")))?;
        let c = match n[..] {
            [x] => Rgb::splat(x as f32),
            [r, g, b] if p.tag == "rgb" => Rgb::new(r as f32, g as f32, b as f32),
            _ => {
                return Err(p.at.error(format!(
                    "'{name}' needs {} value(s), got {}",
                    if p.tag == "rgb" { "1 or 3" } else { "1" },
                    n.len()
                )));
            }
        };
        Ok(Some(c))
    }

    pub fn point(&self, name: &str) -> Result<Option<DVec3>, SceneError> {
        match self.typed(name, &["point", "vector"])? {
            Some(p) => {
                p.only_attrs(&["name", "value", "x", "y", "z"])?;
                vector(p, 0.0).map(Some)
            }
            None => Ok(None),
        }
    }

    pub fn transform(&self, name: &str) -> Result<Option<DMat4>, SceneError> {
        match self.typed(name, &["transform"])? {
            Some(p) => {
                p.only_attrs(&["name"])?;
                transform(p).map(Some)
            }
            None => Ok(None),
        }
    }

    /// Nested plugins and references among the children (`<bsdf>`, `<ref>`, …), marked as read.
    pub fn nested(&self, tags: &[&str]) -> Vec<&'a Element> {
        let mut out = Vec::new();
        for (i, c) in self.el.children.iter().enumerate() {
            if tags.contains(&c.tag.as_str()) {
                self.used.borrow_mut()[i] = true;
                out.push(c);
            }
        }
        out
    }

    /// The nested plugin or reference (tag among `tags`) bound to parameter `name`, marked as read.
    pub fn nested_named(&self, name: &str, tags: &[&str]) -> Option<&'a Element> {
        let i = self
            .el
            .children
            .iter()
            .position(|c| tags.contains(&c.tag.as_str()) && c.attr("name") == Some(name))?;
        self.used.borrow_mut()[i] = true;
        Some(&self.el.children[i])
    }

    /// The first child nobody read is an error: an unknown parameter or an unsupported nested
    /// plugin.
    pub fn finish(&self) -> Result<(), SceneError> {
        let used = self.used.borrow();
        match self.el.children.iter().zip(used.iter()).find(|(_, u)| !**u) {
            Some((c, _)) => {
                let what = match c.attr("name") {
                    Some(n) if PROPERTY_TAGS.contains(&c.tag.as_str()) => {
                        format!("parameter '{n}'")
                    }
                    _ => format!("<{}>", c.tag),
                };
                Err(c.at.error(format!(
                    "{what} of {} is not supported by Lightlab's importer (see scenes/README.md, \
                     \"Mitsuba scenes\")",
                    self.describe()
                )))
            }
            None => Ok(()),
        }
    }
}

fn describe(el: &Element) -> String {
    let mut s = format!("<{}", el.tag);
    for key in ["type", "id"] {
        if let Some(v) = el.attr(key) {
            s.push_str(&format!(" {key}=\"{v}\""));
        }
    }
    s + ">"
}

/// Numbers separated by commas and/or white space.
pub(crate) fn numbers(s: &str) -> Result<Vec<f64>, String> {
    let v: Result<Vec<f64>, _> = s
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|w| !w.is_empty())
        .map(|w| w.parse::<f64>())
        .collect();
    match v {
        Ok(v) if !v.is_empty() && v.iter().all(|x| x.is_finite()) => Ok(v),
        _ => Err(format!("'{s}' is not a list of finite numbers")),
    }
}

/// A vector from `value="x, y, z"` or `x`/`y`/`z` attributes (missing ones are `default`).
fn vector(e: &Element, default: f64) -> Result<DVec3, SceneError> {
    if let Some(v) = e.attr("value") {
        if ["x", "y", "z"].iter().any(|k| e.attr(k).is_some()) {
            return Err(e
                .at
                .error(format!("<{}> has both value and x/y/z: give one", e.tag)));
        }
        let n = numbers(v).map_err(|m| e.at.error(m))?;
        return match n[..] {
            [x, y, z] => Ok(DVec3::new(x, y, z)),
            _ => Err(e.at.error(format!(
                "<{}> value needs 3 numbers, got {}",
                e.tag,
                n.len()
            ))),
        };
    }
    let mut out = DVec3::splat(default);
    for (i, k) in ["x", "y", "z"].into_iter().enumerate() {
        if let Some(v) = e.attr(k) {
            out[i] = match v.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => return Err(e.at.error(format!("<{}> {k}='{v}' is not a number", e.tag))),
            };
        }
    }
    Ok(out)
}

/// A `<transform>`: its children applied in order, each multiplying from the left (Mitsuba 3).
fn transform(t: &Element) -> Result<DMat4, SceneError> {
    let mut m = DMat4::IDENTITY;
    for c in &t.children {
        let step = match c.tag.as_str() {
            "translate" => {
                c.only_attrs(&["value", "x", "y", "z"])?;
                DMat4::from_translation(vector(c, 0.0)?)
            }
            "scale" => {
                c.only_attrs(&["value", "x", "y", "z"])?;
                let s = match c.attr("value").map(numbers) {
                    Some(Ok(n)) if n.len() == 1 => DVec3::splat(n[0]),
                    _ => vector(c, 1.0)?,
                };
                if s.x == 0.0 || s.y == 0.0 || s.z == 0.0 {
                    return Err(c.at.error(
                        "<scale> by zero collapses what the transform places (a shape, a light's \
                         frame, texture coordinates) onto a plane or a point",
                    ));
                }
                DMat4::from_scale(s)
            }
            "rotate" => {
                c.only_attrs(&["value", "x", "y", "z", "angle"])?;
                let axis = vector(c, 0.0)?;
                if axis.length_squared() == 0.0 {
                    return Err(c.at.error("<rotate> needs a non-zero axis"));
                }
                let angle: f64 = c
                    .require("angle")?
                    .trim()
                    .parse()
                    .map_err(|_| c.at.error("<rotate> angle is not a number"))?;
                rotation(axis, angle.to_radians())
            }
            "matrix" => {
                c.only_attrs(&["value"])?;
                let n = numbers(c.require("value")?).map_err(|e| c.at.error(e))?;
                match n.len() {
                    // Row-major in the file; glam is column-major. Shapes, cameras and lights
                    // take affine maps: a projective bottom row (Mitsuba divides by w) is refused
                    // rather than dropped.
                    16 if n[12..16] != [0.0, 0.0, 0.0, 1.0] => {
                        return Err(c.at.error(format!(
                            "<matrix> bottom row must be 0 0 0 1 (an affine transform), got {} {} {} {}",
                            n[12], n[13], n[14], n[15]
                        )));
                    }
                    16 => DMat4::from_cols_slice(&n).transpose(),
                    9 => DMat4::from_mat3(DMat3::from_cols_slice(&n).transpose()),
                    k => {
                        return Err(c
                            .at
                            .error(format!("<matrix> needs 16 (or 9) numbers, got {k}")));
                    }
                }
            }
            "lookat" => {
                c.only_attrs(&["origin", "target", "up"])?;
                let parse = |k: &str| -> Result<DVec3, SceneError> {
                    let n = numbers(c.require(k)?).map_err(|e| c.at.error(e))?;
                    match n[..] {
                        [x, y, z] => Ok(DVec3::new(x, y, z)),
                        _ => Err(c.at.error(format!("<lookat> {k} needs 3 numbers"))),
                    }
                };
                let (origin, target) = (parse("origin")?, parse("target")?);
                let dir = (target - origin).normalize_or_zero();
                if dir == DVec3::ZERO {
                    return Err(c.at.error("<lookat> origin and target coincide"));
                }
                let up = match c.attr("up") {
                    Some(_) => parse("up")?,
                    None => dir.any_orthonormal_vector(),
                };
                // Mitsuba's look-at frame: columns (left, up, dir, origin) with left = up × dir.
                let left = up.cross(dir).normalize_or_zero();
                if left == DVec3::ZERO {
                    return Err(c.at.error("<lookat> up is parallel to the view direction"));
                }
                let up = dir.cross(left);
                DMat4::from_cols(
                    left.extend(0.0),
                    up.extend(0.0),
                    dir.extend(0.0),
                    origin.extend(1.0),
                )
            }
            other => {
                return Err(c.at.error(format!(
                    "<{other}> is not a transform step (translate, scale, rotate, matrix, lookat)"
                )));
            }
        };
        m = step * m;
    }
    if !m.is_finite() || m.determinant() == 0.0 {
        return Err(t.at.error("the transform is singular or not finite"));
    }
    Ok(m)
}

/// Mitsuba 3's rotation about `a` by `theta`: Rodrigues' formula cos θ·I + sin θ·[a]× +
/// (1 − cos θ)·a aᵀ with the axis as given. Mitsuba does not normalise it, so an axis that is not
/// unit length (e.g. `x="1" y="1"`) gives a rotation combined with a scale and shear; the import
/// reproduces that exactly.
fn rotation(a: DVec3, theta: f64) -> DMat4 {
    let (s, c) = theta.sin_cos();
    let outer = DMat3::from_cols(a * a.x, a * a.y, a * a.z);
    let cross = DMat3::from_cols(
        DVec3::new(0.0, a.z, -a.y),
        DVec3::new(-a.z, 0.0, a.x),
        DVec3::new(a.y, -a.x, 0.0),
    );
    DMat4::from_mat3(DMat3::IDENTITY * c + cross * s + outer * (1.0 - c))
}
