//! Multiple importance sampling heuristics (Veach and Guibas 1995; Veach 1997, §9.2).

/// Balance heuristic w = n_f p_f / Σ n_i p_i (Veach 1997, eq. 9.6) for two strategies.
#[inline]
pub fn balance_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let f = nf * f_pdf;
    let g = ng * g_pdf;
    if f == 0.0 {
        0.0
    } else if f.is_infinite() {
        1.0
    } else {
        f / (f + g)
    }
}

/// Power heuristic with β = 2 (Veach 1997, eq. 9.13) for two strategies.
#[inline]
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let f = nf * f_pdf;
    let g = ng * g_pdf;
    if f == 0.0 {
        0.0
    } else if f.is_infinite() || g == 0.0 {
        1.0
    } else {
        // Divide first so that large pdfs do not overflow when squared.
        let r = g / f;
        1.0 / (1.0 + r * r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one() {
        for (a, b) in [(0.3, 2.0), (1e-30, 1e30), (5.0, 5.0), (1e20, 3e19)] {
            assert!(
                (balance_heuristic(1.0, a, 1.0, b) + balance_heuristic(1.0, b, 1.0, a) - 1.0).abs()
                    < 1e-6
            );
            assert!(
                (power_heuristic(1.0, a, 1.0, b) + power_heuristic(1.0, b, 1.0, a) - 1.0).abs()
                    < 1e-6
            );
        }
        assert_eq!(power_heuristic(1.0, f32::INFINITY, 1.0, 3.0), 1.0);
        assert_eq!(power_heuristic(1.0, 0.0, 1.0, 3.0), 0.0);
        assert_eq!(power_heuristic(1.0, 0.5, 1.0, 0.5), 0.5);
        assert!((power_heuristic(1.0, 1.0, 1.0, 2.0) - 0.2).abs() < 1e-7);
    }
}
