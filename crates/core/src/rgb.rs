//! Three independent radiometric channels (design.md: RGB radiometry, no spectral rendering).

use serde::{Deserialize, Serialize};
use std::ops::{Add, AddAssign, Div, DivAssign, Index, Mul, MulAssign, Sub};

/// An RGB triple of radiometric quantities (radiance, intensity, albedo, throughput …).
///
/// In RON it is written as a tuple `(r, g, b)`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(from = "(f32, f32, f32)", into = "(f32, f32, f32)")]
pub struct Rgb {
    pub r: f32,
    pub g: f32,
    pub b: f32,
}

impl Rgb {
    pub const BLACK: Rgb = Rgb::splat(0.0);
    pub const WHITE: Rgb = Rgb::splat(1.0);

    #[inline]
    pub const fn new(r: f32, g: f32, b: f32) -> Self {
        Rgb { r, g, b }
    }
    #[inline]
    pub const fn splat(v: f32) -> Self {
        Rgb { r: v, g: v, b: v }
    }
    #[inline]
    pub fn is_black(self) -> bool {
        self.r == 0.0 && self.g == 0.0 && self.b == 0.0
    }
    #[inline]
    pub fn is_finite(self) -> bool {
        self.r.is_finite() && self.g.is_finite() && self.b.is_finite()
    }
    #[inline]
    pub fn max_component(self) -> f32 {
        self.r.max(self.g).max(self.b)
    }
    #[inline]
    pub fn min_component(self) -> f32 {
        self.r.min(self.g).min(self.b)
    }
    /// Arithmetic mean of the channels; the scalar used for power-proportional light selection.
    #[inline]
    pub fn average(self) -> f32 {
        (self.r + self.g + self.b) / 3.0
    }
    /// Rec. 709 luminance.
    #[inline]
    pub fn luminance(self) -> f32 {
        0.2126 * self.r + 0.7152 * self.g + 0.0722 * self.b
    }
    #[inline]
    pub fn map(self, f: impl Fn(f32) -> f32) -> Rgb {
        Rgb::new(f(self.r), f(self.g), f(self.b))
    }
    #[inline]
    pub fn to_array(self) -> [f32; 3] {
        [self.r, self.g, self.b]
    }
}

impl From<(f32, f32, f32)> for Rgb {
    fn from((r, g, b): (f32, f32, f32)) -> Self {
        Rgb::new(r, g, b)
    }
}
impl From<Rgb> for (f32, f32, f32) {
    fn from(c: Rgb) -> Self {
        (c.r, c.g, c.b)
    }
}
impl From<[f32; 3]> for Rgb {
    fn from([r, g, b]: [f32; 3]) -> Self {
        Rgb::new(r, g, b)
    }
}

impl Index<usize> for Rgb {
    type Output = f32;
    fn index(&self, i: usize) -> &f32 {
        match i {
            0 => &self.r,
            1 => &self.g,
            2 => &self.b,
            _ => panic!("Rgb channel index {i} out of range 0..3"),
        }
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $tra:ident, $fa:ident, $op:tt) => {
        impl $tr for Rgb {
            type Output = Rgb;
            #[inline]
            fn $f(self, o: Rgb) -> Rgb {
                Rgb::new(self.r $op o.r, self.g $op o.g, self.b $op o.b)
            }
        }
        impl $tr<f32> for Rgb {
            type Output = Rgb;
            #[inline]
            fn $f(self, s: f32) -> Rgb {
                Rgb::new(self.r $op s, self.g $op s, self.b $op s)
            }
        }
        impl $tra for Rgb {
            #[inline]
            fn $fa(&mut self, o: Rgb) {
                *self = *self $op o;
            }
        }
        impl $tra<f32> for Rgb {
            #[inline]
            fn $fa(&mut self, s: f32) {
                *self = *self $op s;
            }
        }
    };
}
binop!(Add, add, AddAssign, add_assign, +);
binop!(Mul, mul, MulAssign, mul_assign, *);
binop!(Div, div, DivAssign, div_assign, /);

impl Sub for Rgb {
    type Output = Rgb;
    #[inline]
    fn sub(self, o: Rgb) -> Rgb {
        Rgb::new(self.r - o.r, self.g - o.g, self.b - o.b)
    }
}
impl Mul<Rgb> for f32 {
    type Output = Rgb;
    #[inline]
    fn mul(self, c: Rgb) -> Rgb {
        c * self
    }
}
