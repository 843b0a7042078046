//! Textures: an RGB value that varies over a surface with its (u, v) parameterisation — a bitmap
//! image or a checkerboard — and the material parameters they replace.
//!
//! Lookups follow Mitsuba 3's `bitmap` and `checkerboard` plugins exactly (values read off
//! Mitsuba 3.9.1 in the tests): `to_uv` maps the surface's (u, v) first; image row 0 is the top row
//! and lies at v = 0, so texel (x, y) covers u ∈ [x/w, (x+1)/w), v ∈ [y/h, (y+1)/h); bilinear
//! filtering interpolates between texel centres (coordinate u·w − ½), and wrapping applies to the
//! integer texel indices.

use glam::Affine2;
use lightlab_core::{Rgb, Vec2};

/// How a bitmap is sampled between texels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// The texel the point falls in.
    Nearest,
    /// Bilinear interpolation of the four nearest texel centres (Mitsuba's default).
    #[default]
    Bilinear,
}

/// What a bitmap shows outside [0, 1)².
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// Tiles the image (Mitsuba's default).
    #[default]
    Repeat,
    /// Tiles it reflected at every edge.
    Mirror,
    /// Extends the edge texels.
    Clamp,
}

impl Wrap {
    /// Texel index `i` of a row (or column) of `n` texels, wrapped into 0..n.
    #[inline]
    fn index(self, i: i64, n: usize) -> usize {
        let n = n as i64;
        match self {
            Wrap::Repeat => i.rem_euclid(n) as usize,
            Wrap::Clamp => i.clamp(0, n - 1) as usize,
            Wrap::Mirror => {
                let k = i.rem_euclid(2 * n);
                (if k >= n { 2 * n - 1 - k } else { k }) as usize
            }
        }
    }
}

/// An RGB image in linear values (any sRGB decoding happened when it was read), row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Bitmap {
    width: usize,
    height: usize,
    texels: Vec<Rgb>,
    pub filter: Filter,
    pub wrap: Wrap,
}

impl Bitmap {
    /// `texels` row by row from the top, `width × height` of them (both > 0).
    pub fn new(
        width: usize,
        height: usize,
        texels: Vec<Rgb>,
        filter: Filter,
        wrap: Wrap,
    ) -> Result<Bitmap, String> {
        if width == 0 || height == 0 || texels.len() != width * height {
            return Err(format!(
                "a {width} × {height} image needs {} texels, got {}",
                width * height,
                texels.len()
            ));
        }
        Ok(Bitmap {
            width,
            height,
            texels,
            filter,
            wrap,
        })
    }

    #[inline]
    fn texel(&self, x: i64, y: i64) -> Rgb {
        self.texels[self.wrap.index(y, self.height) * self.width + self.wrap.index(x, self.width)]
    }

    /// The value at texture coordinates `uv` (after `to_uv`).
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let (w, h) = (self.width as f64, self.height as f64);
        let (u, v) = (uv.x as f64, uv.y as f64);
        match self.filter {
            Filter::Nearest => self.texel((u * w).floor() as i64, (v * h).floor() as i64),
            Filter::Bilinear => {
                let (x, y) = (u * w - 0.5, v * h - 0.5);
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let top = self.texel(x0, y0) * (1.0 - fx) + self.texel(x0 + 1, y0) * fx;
                let bottom = self.texel(x0, y0 + 1) * (1.0 - fx) + self.texel(x0 + 1, y0 + 1) * fx;
                top * (1.0 - fy) + bottom * fy
            }
        }
    }

    /// The largest value of any channel of any texel (a bound on every filtered value).
    pub fn max_value(&self) -> f32 {
        self.texels
            .iter()
            .map(|t| t.max_component())
            .fold(0.0, f32::max)
    }

    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }
}

/// What a texture shows.
#[derive(Clone, Debug, PartialEq)]
pub enum Pattern {
    Bitmap(Bitmap),
    /// `color0` where ⌊2u⌋ + ⌊2v⌋ is even (on the half-open squares [0, ½)), `color1` elsewhere:
    /// a 2 × 2 board per unit square of (u, v), Mitsuba's `checkerboard`.
    Checkerboard {
        color0: Rgb,
        color1: Rgb,
    },
}

/// A texture: a pattern placed on the surface's (u, v) by `to_uv`.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub pattern: Pattern,
    /// The map from a surface's (u, v) to the pattern's coordinates.
    pub to_uv: Affine2,
}

impl Texture {
    /// The value at the surface point with parameters `uv`.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let uv = self.to_uv.transform_point2(uv);
        match &self.pattern {
            Pattern::Bitmap(b) => b.eval(uv),
            Pattern::Checkerboard { color0, color1 } => {
                let odd = |x: f32| x - x.floor() > 0.5;
                if odd(uv.x) == odd(uv.y) {
                    *color0
                } else {
                    *color1
                }
            }
        }
    }

    /// The largest value of any channel anywhere on the texture.
    pub fn max_value(&self) -> f32 {
        match &self.pattern {
            Pattern::Bitmap(b) => b.max_value(),
            Pattern::Checkerboard { color0, color1 } => {
                color0.max_component().max(color1.max_component())
            }
        }
    }

    /// The smallest value of any channel anywhere on the texture.
    pub fn min_value(&self) -> f32 {
        match &self.pattern {
            Pattern::Bitmap(b) => b
                .texels
                .iter()
                .map(|t| t.min_component())
                .fold(f32::INFINITY, f32::min),
            Pattern::Checkerboard { color0, color1 } => {
                color0.min_component().min(color1.min_component())
            }
        }
    }
}

/// Which of a material's colour parameters textures replace, as indices into the scene's texture
/// list: `reflectance` is Diffuse's albedo, Mirror's reflectance and Phong's kd; `specular` is
/// Phong's ks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureSlots {
    pub reflectance: Option<u32>,
    pub specular: Option<u32>,
}

impl TextureSlots {
    pub const NONE: TextureSlots = TextureSlots {
        reflectance: None,
        specular: None,
    };

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.reflectance.is_none() && self.specular.is_none()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn colours() -> Vec<Rgb> {
        vec![
            Rgb::new(1.0, 0.0, 0.0),
            Rgb::new(0.0, 1.0, 0.0),
            Rgb::new(0.0, 0.0, 1.0),
            Rgb::new(1.0, 1.0, 0.0),
        ]
    }

    fn close(a: Rgb, b: [f32; 3]) -> bool {
        (a - Rgb::new(b[0], b[1], b[2]))
            .map(f32::abs)
            .max_component()
            < 1e-4
    }

    /// A 2 × 2 image (red, green / blue, yellow) looked up as Mitsuba 3.9.1's `bitmap` does, for
    /// every filter and wrap mode; expected values printed by Mitsuba for the same image.
    #[test]
    fn bitmap_lookups_match_mitsuba() {
        let uvs = [
            (0.25, 0.25),
            (0.75, 0.25),
            (0.25, 0.75),
            (0.5, 0.5),
            (0.1, 0.1),
            (1.1, 0.25),
            (-0.1, 0.25),
            (1.6, 0.25),
        ];
        let (r, g, b, y) = ([1., 0., 0.], [0., 1., 0.], [0., 0., 1.], [1., 1., 0.]);
        let expected: [(Filter, Wrap, [[f32; 3]; 8]); 6] = [
            (Filter::Nearest, Wrap::Repeat, [r, g, b, y, r, r, g, g]),
            (Filter::Nearest, Wrap::Mirror, [r, g, b, y, r, g, r, r]),
            (Filter::Nearest, Wrap::Clamp, [r, g, b, y, r, g, r, g]),
            (
                Filter::Bilinear,
                Wrap::Repeat,
                [
                    r,
                    g,
                    b,
                    [0.5, 0.5, 0.25],
                    [0.58, 0.3, 0.21],
                    [0.7, 0.3, 0.],
                    [0.3, 0.7, 0.],
                    [0.3, 0.7, 0.],
                ],
            ),
            (
                Filter::Bilinear,
                Wrap::Mirror,
                [r, g, b, [0.5, 0.5, 0.25], r, g, r, [0.7, 0.3, 0.]],
            ),
            (
                Filter::Bilinear,
                Wrap::Clamp,
                [r, g, b, [0.5, 0.5, 0.25], r, g, r, g],
            ),
        ];
        for (filter, wrap, values) in expected {
            let t = Texture {
                pattern: Pattern::Bitmap(Bitmap::new(2, 2, colours(), filter, wrap).unwrap()),
                to_uv: Affine2::IDENTITY,
            };
            for (&(u, v), want) in uvs.iter().zip(values) {
                let got = t.eval(Vec2::new(u, v));
                assert!(
                    close(got, want),
                    "{filter:?} {wrap:?} at ({u}, {v}): {got:?}, want {want:?}"
                );
            }
        }
        // to_uv scales before the lookup: (0.3, 0.2) · (2, 3) lands in the yellow texel.
        let t = Texture {
            pattern: Pattern::Bitmap(
                Bitmap::new(2, 2, colours(), Filter::Nearest, Wrap::Repeat).unwrap(),
            ),
            to_uv: Affine2::from_scale(Vec2::new(2.0, 3.0)),
        };
        assert!(close(t.eval(Vec2::new(0.3, 0.2)), y));
    }

    /// Mitsuba 3.9.1's `checkerboard` at the same points.
    #[test]
    fn checkerboard_matches_mitsuba() {
        let t = Texture {
            pattern: Pattern::Checkerboard {
                color0: Rgb::new(1.0, 0.0, 0.0),
                color1: Rgb::new(0.0, 1.0, 0.0),
            },
            to_uv: Affine2::IDENTITY,
        };
        let (c0, c1) = ([1., 0., 0.], [0., 1., 0.]);
        for (uv, want) in [
            ((0.25, 0.25), c0),
            ((0.75, 0.25), c1),
            ((0.25, 0.75), c1),
            ((0.75, 0.75), c0),
            ((1.25, 0.25), c0),
            ((-0.25, 0.25), c1),
            ((0.5, 0.25), c0),
        ] {
            assert!(close(t.eval(Vec2::new(uv.0, uv.1)), want), "{uv:?}");
        }
        assert_eq!(t.max_value(), 1.0);
        assert_eq!(t.min_value(), 0.0);
    }

    #[test]
    fn bitmap_needs_its_texels() {
        assert!(Bitmap::new(2, 2, vec![Rgb::WHITE; 3], Filter::Nearest, Wrap::Repeat).is_err());
        assert!(Bitmap::new(0, 0, vec![], Filter::Nearest, Wrap::Repeat).is_err());
    }
}
