//! Heckbert path classes (Heckbert 1990): the string `L X₁ … X_k E` of a light-transport path,
//! written light first, with one symbol per scattering vertex — `D` diffuse, `G` glossy, `S`
//! specular — as the material's lobe class gives it (`Bsdf::lobe_class`; microfacet surfaces
//! at least as rough as `lightlab_materials::DIFFUSE_ALPHA` count as `D`, smoother ones as `G`).
//! A BSDF that mixes a delta lobe into a non-delta one (plastic) is recorded per path: `S` where
//! the path left it by the delta lobe, its non-delta class otherwise.

use lightlab_materials::LobeClass;

/// Scattering vertices a class records; longer paths are [`PathClass::is_long`] and match only
/// the remainder layer.
pub const MAX_RECORDED: u32 = 32;

/// The scattering vertices of a path (or of part of one), in the order they were pushed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PathClass {
    /// 2 bits per vertex (1 = D, 2 = G, 3 = S), vertex i at bits 2i..2i+2.
    bits: u64,
    /// Number of scattering vertices (may exceed [`MAX_RECORDED`]).
    len: u32,
}

impl PathClass {
    /// No scattering vertex: the path `LE`.
    pub const EMPTY: PathClass = PathClass { bits: 0, len: 0 };

    #[inline]
    fn code(c: LobeClass) -> u64 {
        match c {
            LobeClass::Diffuse => 1,
            LobeClass::Glossy => 2,
            LobeClass::Specular => 3,
        }
    }

    /// This class with one more vertex at the end.
    #[inline]
    pub fn push(self, c: LobeClass) -> PathClass {
        let mut out = self;
        if self.len < MAX_RECORDED {
            out.bits |= Self::code(c) << (2 * self.len);
        }
        out.len = self.len.saturating_add(1);
        out
    }

    /// This class with its last vertex recorded as `c` instead (a vertex whose BSDF mixes delta and
    /// non-delta lobes, left by its delta lobe); unchanged if empty or past [`MAX_RECORDED`].
    #[inline]
    pub fn with_last(self, c: LobeClass) -> PathClass {
        let mut out = self;
        if (1..=MAX_RECORDED).contains(&self.len) {
            let shift = 2 * (self.len - 1);
            out.bits = (self.bits & !(3 << shift)) | Self::code(c) << shift;
        }
        out
    }

    /// This class without its last vertex; unchanged if empty.
    #[inline]
    pub fn without_last(self) -> PathClass {
        let len = self.len.saturating_sub(1);
        let mut out = PathClass {
            bits: self.bits,
            len,
        };
        if len < MAX_RECORDED {
            out.bits &= (1u64 << (2 * len)) - 1;
        }
        out
    }

    /// Number of scattering vertices.
    #[inline]
    pub fn len(&self) -> u32 {
        self.len
    }

    /// Whether the class has no scattering vertex.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// More vertices than are recorded.
    #[inline]
    pub fn is_long(&self) -> bool {
        self.len > MAX_RECORDED
    }

    /// Vertex `i` (0-based, in push order).
    #[inline]
    pub fn get(&self, i: u32) -> LobeClass {
        match (self.bits >> (2 * i)) & 3 {
            1 => LobeClass::Diffuse,
            2 => LobeClass::Glossy,
            _ => LobeClass::Specular,
        }
    }

    /// The vertices in reverse order (a camera path, built eye first, turned light first).
    #[inline]
    pub fn reversed(self) -> PathClass {
        let n = self.len.min(MAX_RECORDED);
        let mut out = PathClass {
            bits: 0,
            len: self.len,
        };
        for i in 0..n {
            out.bits |= ((self.bits >> (2 * i)) & 3) << (2 * (n - 1 - i));
        }
        out
    }

    /// `self` followed by `other`.
    #[inline]
    pub fn then(self, other: PathClass) -> PathClass {
        let mut out = self;
        let room = MAX_RECORDED.saturating_sub(self.len);
        let take = other.len.min(room).min(MAX_RECORDED);
        if take > 0 {
            let mask = if take >= 32 {
                u64::MAX
            } else {
                (1u64 << (2 * take)) - 1
            };
            out.bits |= (other.bits & mask) << (2 * self.len);
        }
        out.len = self.len.saturating_add(other.len);
        out
    }

    /// The full string, e.g. `LSSDE`.
    pub fn to_heckbert(&self) -> String {
        let mut s = String::from("L");
        for i in 0..self.len.min(MAX_RECORDED) {
            s.push(match self.get(i) {
                LobeClass::Diffuse => 'D',
                LobeClass::Glossy => 'G',
                LobeClass::Specular => 'S',
            });
        }
        if self.is_long() {
            s.push('…');
        }
        s.push('E');
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use LobeClass::*;

    #[test]
    fn push_reverse_and_join() {
        let a = PathClass::EMPTY.push(Specular).push(Specular).push(Diffuse);
        assert_eq!(a.to_heckbert(), "LSSDE");
        assert_eq!(a.reversed().to_heckbert(), "LDSSE");
        let b = PathClass::EMPTY.push(Glossy).push(Diffuse);
        assert_eq!(a.then(b).to_heckbert(), "LSSDGDE");
        assert_eq!(a.then(b).len(), 5);
        let mut long = PathClass::EMPTY;
        for _ in 0..40 {
            long = long.push(Diffuse);
        }
        assert!(long.is_long() && long.len() == 40);
        assert_eq!(long.reversed().get(31), Diffuse);
        assert!(PathClass::EMPTY.then(a).then(PathClass::EMPTY) == a);
    }
}
