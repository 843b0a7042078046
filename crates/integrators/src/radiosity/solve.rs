//! Solvers of the discrete radiosity equation B = E + ρ F̂ B (Goral et al. 1984; Cohen & Wallace
//! 1993 ch. 5), one unknown per patch side, all three on the same matrix F̂ (`form_factors`):
//!
//! - **Jacobi**: B⁽ᵏ⁾ = Σ_{j ≤ k} (ρF̂)ʲ E, the Neumann series truncated after k terms — term j is
//!   the light of the paths `L Dʲ E`, which is how `max_bounces`, `min_bounces`, `paths` and
//!   `layers` select terms.
//! - **Gauss–Seidel**: each unknown updated in place, B_a ← E_a + ρ_a Σ_b F̂_ab B_b, in index
//!   order; about twice Jacobi's convergence per sweep on diffuse scenes, but an iterate is no
//!   longer a sum of whole terms.
//! - **Progressive shooting** (Cohen, Chen, Wallace & Greenberg 1988): the side with the most
//!   unshot power A_s ΔB_s shoots it, ΔB_j += ρ_j F̂_js ΔB_s for every j that sees s (Southwell
//!   relaxation; Gortler et al. 1993), so the brightest light spreads first. The invariant
//!   B = E + ρF̂(B − ΔB) makes the residual ρF̂ΔB. For display, the ambient term ρ_a·A with
//!   A = Σ ΔB_a A_a / Σ A_a · 1/(1 − ρ̄), ρ̄ the area-averaged reflectance, stands in for the
//!   light not yet shot (Cohen et al. 1988 §4; an approximation, off by default).
//!
//! The residual recorded after each iteration is the relative residual
//! ‖E + ρF̂B − B‖ / ‖E‖ with ‖x‖ = Σ_a A_a Σ_channels |x_a| (power); for shooting, an iteration is
//! as many shots as there are unknowns that reflect, about the work of one Jacobi sweep.

use super::form_factors::FormFactors;
use rayon::prelude::*;

/// Which solver iterates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Solver {
    /// Jacobi iteration: iterate k is the Neumann series after k terms (bounces).
    #[default]
    Jacobi,
    /// Gauss–Seidel iteration, in place in unknown order.
    GaussSeidel,
    /// Progressive refinement by shooting unshot radiosity (Cohen et al. 1988).
    Shooting,
}

/// The linear system of one scene's patches.
pub(crate) struct System<'f> {
    /// F̂ by rows.
    pub rows: &'f FormFactors,
    /// Reflectance ρ of each unknown (0 for a side that does not scatter).
    pub rho: Vec<[f64; 3]>,
    /// Emitted radiosity E = π Lₑ of each unknown.
    pub emission: Vec<[f64; 3]>,
    /// Area of each unknown's patch.
    pub area: Vec<f64>,
}

/// When to stop: exactly `iterations` if given, else when the relative residual falls below
/// `tolerance` (at most [`MAX_ITERATIONS`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stop {
    pub iterations: Option<u32>,
    pub tolerance: f64,
}

/// Iterations a solve without a fixed count runs at most.
pub(crate) const MAX_ITERATIONS: u32 = 100_000;

/// A solution: the radiosity of each unknown.
pub(crate) struct Solved {
    pub b: Vec<[f64; 3]>,
    /// Iterations done.
    pub iterations: u32,
    /// Relative residual after 0, 1, …, `iterations` iterations.
    pub residuals: Vec<f64>,
    /// Whether a solve without a fixed count reached its tolerance.
    pub converged: bool,
    /// Shots fired (progressive shooting).
    pub shots: u64,
}

impl System<'_> {
    fn len(&self) -> usize {
        self.rho.len()
    }

    fn reflects(&self, a: usize) -> bool {
        self.rho[a].iter().any(|&r| r > 0.0)
    }

    /// (ρF̂x)_a.
    #[inline]
    fn transport(&self, a: usize, x: &[[f64; 3]]) -> [f64; 3] {
        if !self.reflects(a) {
            return [0.0; 3];
        }
        let g = self.rows.gather(a, x);
        std::array::from_fn(|c| self.rho[a][c] * g[c])
    }

    /// ρF̂x for every unknown.
    fn apply(&self, x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        (0..self.len())
            .into_par_iter()
            .map(|a| self.transport(a, x))
            .collect()
    }

    /// ‖x‖: area-weighted, summed over channels.
    fn norm(&self, x: &[[f64; 3]]) -> f64 {
        x.iter()
            .zip(&self.area)
            .map(|(v, a)| a * (v[0].abs() + v[1].abs() + v[2].abs()))
            .sum()
    }

    /// ‖E + ρF̂B − B‖ / ‖E‖ (0 when nothing emits).
    fn residual(&self, b: &[[f64; 3]]) -> f64 {
        let t = self.apply(b);
        let r: Vec<[f64; 3]> = (0..self.len())
            .map(|a| std::array::from_fn(|c| self.emission[a][c] + t[a][c] - b[a][c]))
            .collect();
        self.relative(self.norm(&r))
    }

    fn relative(&self, norm: f64) -> f64 {
        let e = self.norm(&self.emission);
        if e > 0.0 { norm / e } else { 0.0 }
    }

    /// Jacobi iteration. `term(k, t)` receives the k-th term (ρF̂)ᵏE of the series as it is made.
    pub fn jacobi(&self, stop: Stop, term: &mut dyn FnMut(u32, &[[f64; 3]])) -> Solved {
        let mut b = self.emission.clone();
        let mut t = self.emission.clone();
        term(0, &t);
        let mut residuals = Vec::new();
        let mut k = 0;
        let converged = loop {
            // The residual of B⁽ᵏ⁾ is the next term.
            let next = self.apply(&t);
            let r = self.relative(self.norm(&next));
            residuals.push(r);
            if done(stop, k, r) {
                break r < stop.tolerance;
            }
            k += 1;
            t = next;
            for (x, y) in b.iter_mut().zip(&t) {
                for c in 0..3 {
                    x[c] += y[c];
                }
            }
            term(k, &t);
        };
        Solved {
            b,
            iterations: k,
            residuals,
            converged,
            shots: 0,
        }
    }

    /// Gauss–Seidel iteration from B = E.
    pub fn gauss_seidel(&self, stop: Stop) -> Solved {
        let mut b = self.emission.clone();
        let mut residuals = vec![self.residual(&b)];
        let mut k = 0;
        let converged = loop {
            let r = residuals[k as usize];
            if done(stop, k, r) {
                break r < stop.tolerance;
            }
            for a in 0..self.len() {
                let t = self.transport(a, &b);
                b[a] = std::array::from_fn(|c| self.emission[a][c] + t[c]);
            }
            k += 1;
            residuals.push(self.residual(&b));
        };
        Solved {
            b,
            iterations: k,
            residuals,
            converged,
            shots: 0,
        }
    }

    /// Progressive shooting from B = ΔB = E; returns the solution and the unshot radiosity ΔB.
    pub fn shoot(&self, stop: Stop) -> (Solved, Vec<[f64; 3]>) {
        let columns = self.rows.columns();
        let n = self.len();
        let reflecting = (0..n).filter(|&a| self.reflects(a)).count().max(1);
        let mut b = self.emission.clone();
        let mut unshot = self.emission.clone();
        let power = |a: usize, u: &[[f64; 3]]| self.area[a] * (u[a][0] + u[a][1] + u[a][2]);
        let mut queue = MaxTree::new((0..n).map(|a| power(a, &unshot)).collect());
        let mut residuals = vec![self.residual(&b)];
        let (mut k, mut shots) = (0u32, 0u64);
        let inv = 1.0 / self.rows.rays as f64;
        let converged = 'iterations: loop {
            let r = residuals[k as usize];
            if done(stop, k, r) {
                break r < stop.tolerance;
            }
            for _ in 0..reflecting {
                let s = queue.argmax();
                if !(queue.value(s) > 0.0) {
                    // Nothing left to shoot: B is the solution.
                    k += 1;
                    residuals.push(self.residual(&b));
                    break 'iterations true;
                }
                let shot = std::mem::replace(&mut unshot[s], [0.0; 3]);
                queue.set(s, 0.0);
                shots += 1;
                for &(j, count) in columns.row(s) {
                    let j = j as usize;
                    let f = count as f64 * inv;
                    for c in 0..3 {
                        let received = self.rho[j][c] * f * shot[c];
                        unshot[j][c] += received;
                        b[j][c] += received;
                    }
                    queue.set(j, power(j, &unshot));
                }
            }
            k += 1;
            residuals.push(self.residual(&b));
        };
        (
            Solved {
                b,
                iterations: k,
                residuals,
                converged,
                shots,
            },
            unshot,
        )
    }

    /// Cohen et al. (1988)'s ambient radiosity for the unshot ΔB: Σ ΔB_a A_a / Σ A_a over the
    /// unknowns that other patches see, times 1/(1 − ρ̄) for ρ̄ their area-averaged reflectance.
    /// A side that nothing sees (the outside of a closed shape, facing empty space) neither
    /// receives light nor passes its own on: counted, it made the furnace's image 22 % too bright
    /// after one round of shots. A light that reflects nothing counts: its unshot emission is most
    /// of what is left to shoot (left out, the term added nothing before the first shots). Seen
    /// means a column of F̂ that is not empty: a side that does not reflect has no row.
    /// In a closed sphere of uniform ρ, where F_ab = A_b / A, the term is exact:
    /// (I − ρF)⁻¹ρFΔB = ρ ΔB̄ / (1 − ρ).
    pub fn ambient(&self, unshot: &[[f64; 3]]) -> [f64; 3] {
        let (mut area, mut rho, mut du) = (0.0, [0.0; 3], [0.0; 3]);
        let seen = self.rows.columns();
        let exchanges = |a: usize| !seen.row(a).is_empty();
        for a in (0..self.len()).filter(|&a| exchanges(a)) {
            area += self.area[a];
            for c in 0..3 {
                rho[c] += self.rho[a][c] * self.area[a];
                du[c] += unshot[a][c] * self.area[a];
            }
        }
        if !(area > 0.0) {
            return [0.0; 3];
        }
        std::array::from_fn(|c| {
            let mean_rho = rho[c] / area;
            if mean_rho < 1.0 {
                du[c] / area / (1.0 - mean_rho)
            } else {
                0.0
            }
        })
    }
}

/// Whether a solve stops after `k` iterations with relative residual `r`.
fn done(stop: Stop, k: u32, r: f64) -> bool {
    match stop.iterations {
        Some(n) => k >= n,
        None => r < stop.tolerance || k >= MAX_ITERATIONS,
    }
}

/// A tournament tree over values: the index of the largest in O(1), an update in O(log n); ties
/// go to the lower index, so shooting's order is deterministic.
struct MaxTree {
    values: Vec<f64>,
    /// Node i ≥ 1 holds the winning index of its subtree; leaves start at `leaves`.
    nodes: Vec<u32>,
    leaves: usize,
}

impl MaxTree {
    fn new(mut values: Vec<f64>) -> MaxTree {
        let leaves = values.len().next_power_of_two().max(1);
        // Padding leaves never win.
        values.resize(leaves, f64::NEG_INFINITY);
        let mut nodes = vec![0u32; 2 * leaves];
        for i in 0..leaves {
            nodes[leaves + i] = i as u32;
        }
        let mut tree = MaxTree {
            values,
            nodes,
            leaves,
        };
        for i in (1..leaves).rev() {
            tree.nodes[i] = tree.winner(tree.nodes[2 * i], tree.nodes[2 * i + 1]);
        }
        tree
    }

    fn winner(&self, a: u32, b: u32) -> u32 {
        let (va, vb) = (self.values[a as usize], self.values[b as usize]);
        if vb > va || (vb == va && b < a) { b } else { a }
    }

    fn argmax(&self) -> usize {
        self.nodes[1.min(self.nodes.len() - 1)] as usize
    }

    fn value(&self, i: usize) -> f64 {
        self.values[i]
    }

    fn set(&mut self, i: usize, v: f64) {
        self.values[i] = v;
        let mut node = (self.leaves + i) / 2;
        while node >= 1 {
            self.nodes[node] = self.winner(self.nodes[2 * node], self.nodes[2 * node + 1]);
            node /= 2;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::MaxTree;

    #[test]
    fn max_tree_tracks_the_largest_value_lowest_index_first() {
        let mut t = MaxTree::new(vec![1.0, 5.0, 5.0, 2.0, 0.5]);
        assert_eq!(t.argmax(), 1);
        t.set(1, 0.0);
        assert_eq!(t.argmax(), 2);
        t.set(4, 9.0);
        assert_eq!(t.argmax(), 4);
        t.set(4, 0.0);
        t.set(2, 0.0);
        assert_eq!(t.argmax(), 3);
        let single = MaxTree::new(vec![3.0]);
        assert_eq!(single.argmax(), 0);
    }
}
