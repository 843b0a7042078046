//! Points sampled on shapes for light sampling, and the change of measure from area to solid angle
//! (pbrt-v4 §4.2.3: dω = |cos θ| dA / r²).

use lightlab_core::Vec3;

/// A point sampled on a shape for light sampling.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceSample {
    pub p: Vec3,
    /// Conservative absolute error bound of `p` per axis, for [`spawn_ray_to`](crate::spawn_ray_to).
    pub p_error: Vec3,
    /// Unit geometric normal at `p` (the shape's orientation, not flipped towards anything).
    pub n: Vec3,
    /// Area measure for `sample_area`, solid angle at the reference point for `sample_solid_angle`.
    pub pdf: f32,
}

/// Solid-angle density at `ref_p` of a point `p` with normal `n` sampled with area density `pdf_a`:
/// `pdf_a · d² / |cos θ|`. Infinite when the point is seen edge-on, 0 for a shape without area.
#[inline]
pub(crate) fn pdf_area_to_solid_angle(pdf_a: f32, ref_p: Vec3, p: Vec3, n: Vec3) -> f32 {
    if pdf_a == 0.0 {
        return 0.0;
    }
    let to_ref = ref_p - p;
    let dist_sq = to_ref.length_squared();
    let cos = n.dot(to_ref).abs() / dist_sq.sqrt();
    pdf_a * dist_sq / cos
}

/// An area sample re-expressed in solid angle at `ref_p`; `None` when that density is degenerate
/// (zero, infinite or NaN).
#[inline]
pub(crate) fn area_sample_to_solid_angle(s: SurfaceSample, ref_p: Vec3) -> Option<SurfaceSample> {
    let pdf = pdf_area_to_solid_angle(s.pdf, ref_p, s.p, s.n);
    (pdf.is_finite() && pdf > 0.0).then_some(SurfaceSample { pdf, ..s })
}
