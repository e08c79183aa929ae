//! Natural cubic spline through the tube's waypoints (the generator curve before resampling).
//!
//! Parameter `u` is the cumulative chord length between waypoints (m), which keeps the
//! parameter speed close to 1. Natural end conditions (zero second derivative) make the
//! curve C^2, so the curvature `kappa` is continuous. Half-widths are interpolated between
//! waypoints with a smoothstep in `u` (C^1, no overshoot: a width never leaves the range of
//! its two waypoints).
#![allow(clippy::indexing_slicing)] // construction only; every index is loop-bounded by `n <= W`

use crate::{TubeError, Vec2};

/// One waypoint of the generator curve with the tube's half-widths there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waypoint {
    /// Position, m (world ENU, horizontal).
    pub pos_m: Vec2,
    /// Half-width to the left of the direction of travel, m.
    pub w_left_m: f32,
    /// Half-width to the right of the direction of travel, m.
    pub w_right_m: f32,
}

impl Waypoint {
    /// A waypoint at `(x, y)` m with half-widths `w_left`, `w_right` m.
    pub const fn new(x_m: f32, y_m: f32, w_left_m: f32, w_right_m: f32) -> Self {
        Self { pos_m: Vec2::new(x_m, y_m), w_left_m, w_right_m }
    }
}

/// Gauss-Legendre 5-point nodes on [-1, 1].
const GL5_NODES: [f32; 5] = [0.0, -0.538_469_3, 0.538_469_3, -0.906_179_85, 0.906_179_85];
/// Gauss-Legendre 5-point weights.
const GL5_WEIGHTS: [f32; 5] = [0.568_888_9, 0.478_628_67, 0.478_628_67, 0.236_926_88, 0.236_926_88];

/// A natural cubic spline through up to `W` waypoints.
#[derive(Debug, Clone)]
pub struct Spline<const W: usize> {
    n: usize,
    u: [f32; W],
    p: [Vec2; W],
    /// Second derivatives at the knots (x and y).
    m: [Vec2; W],
    wl: [f32; W],
    wr: [f32; W],
}

impl<const W: usize> Spline<W> {
    /// Fits the spline through `waypoints`.
    ///
    /// # Errors
    /// [`TubeError::TooFewWaypoints`], [`TubeError::TooManyWaypoints`],
    /// [`TubeError::NonFinite`], [`TubeError::NonPositiveWidth`],
    /// [`TubeError::CoincidentWaypoints`].
    pub fn new(waypoints: &[Waypoint]) -> Result<Self, TubeError> {
        const { assert!(W >= 2, "a spline needs room for at least two waypoints") };
        let n = waypoints.len();
        if n < 2 {
            return Err(TubeError::TooFewWaypoints);
        }
        if n > W {
            return Err(TubeError::TooManyWaypoints { capacity: W });
        }
        let mut s = Self {
            n,
            u: [0.0; W],
            p: [Vec2::zeros(); W],
            m: [Vec2::zeros(); W],
            wl: [0.0; W],
            wr: [0.0; W],
        };
        for (i, w) in waypoints.iter().enumerate() {
            let finite = w.pos_m.x.is_finite()
                && w.pos_m.y.is_finite()
                && w.w_left_m.is_finite()
                && w.w_right_m.is_finite();
            if !finite {
                return Err(TubeError::NonFinite { index: i });
            }
            if w.w_left_m <= 0.0 || w.w_right_m <= 0.0 {
                return Err(TubeError::NonPositiveWidth { index: i });
            }
            s.p[i] = w.pos_m;
            s.wl[i] = w.w_left_m;
            s.wr[i] = w.w_right_m;
            if i > 0 {
                let chord = vt_fpu::norm(&(w.pos_m - s.p[i - 1]));
                if !(chord > 1e-4) {
                    return Err(TubeError::CoincidentWaypoints { index: i });
                }
                s.u[i] = s.u[i - 1] + chord;
            }
        }
        s.solve_second_derivatives();
        Ok(s)
    }

    /// Thomas algorithm for the natural-spline tridiagonal system (both coordinates at once).
    fn solve_second_derivatives(&mut self) {
        let n = self.n;
        if n < 3 {
            return; // a straight segment: all second derivatives zero
        }
        // Interior unknowns 1..n-1; c' and d' of the forward sweep.
        let mut cp = [0.0f32; W];
        let mut dp = [Vec2::zeros(); W];
        for i in 1..n - 1 {
            let h0 = self.u[i] - self.u[i - 1];
            let h1 = self.u[i + 1] - self.u[i];
            let rhs = ((self.p[i + 1] - self.p[i]) / h1 - (self.p[i] - self.p[i - 1]) / h0) * 6.0;
            let a = if i > 1 { h0 } else { 0.0 };
            let b = 2.0 * (h0 + h1);
            let c = if i < n - 2 { h1 } else { 0.0 };
            let denom = b - a * cp[i - 1];
            cp[i] = c / denom;
            dp[i] = (rhs - dp[i - 1] * a) / denom;
        }
        self.m[n - 2] = dp[n - 2];
        for i in (1..n - 2).rev() {
            self.m[i] = dp[i] - self.m[i + 1] * cp[i];
        }
    }

    /// Number of waypoints.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Always false: a spline has at least two waypoints.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Knot `j` (cumulative chord length at waypoint `j`, clamped to the last), m.
    pub fn knot(&self, j: usize) -> f32 {
        self.u[j.min(self.n - 1)]
    }

    /// Parameter range end (total chord length), m.
    pub fn param_end(&self) -> f32 {
        self.u[self.n - 1]
    }

    /// Index `j` of the piece `[u_j, u_{j+1}]` holding `u` (clamped to the ends).
    fn piece(&self, u: f32) -> usize {
        let mut j = 0;
        while j + 2 < self.n && u > self.u[j + 1] {
            j += 1;
        }
        j
    }

    /// Position, first and second derivative with respect to `u` at parameter `u`.
    pub fn eval(&self, u: f32) -> (Vec2, Vec2, Vec2) {
        let j = self.piece(u);
        let h = self.u[j + 1] - self.u[j];
        let a = (self.u[j + 1] - u) / h;
        let b = (u - self.u[j]) / h;
        let (p0, p1, m0, m1) = (self.p[j], self.p[j + 1], self.m[j], self.m[j + 1]);
        let pos = p0 * a + p1 * b + (m0 * (a * a * a - a) + m1 * (b * b * b - b)) * (h * h / 6.0);
        let d1 = (p1 - p0) / h - m0 * ((3.0 * a * a - 1.0) * h / 6.0)
            + m1 * ((3.0 * b * b - 1.0) * h / 6.0);
        let d2 = m0 * a + m1 * b;
        (pos, d1, d2)
    }

    /// Half-widths `(w_L, w_R)` at parameter `u`, m (smoothstep between waypoints).
    pub fn widths(&self, u: f32) -> (f32, f32) {
        let j = self.piece(u);
        let h = self.u[j + 1] - self.u[j];
        let t = ((u - self.u[j]) / h).clamp(0.0, 1.0);
        let k = t * t * (3.0 - 2.0 * t);
        (
            self.wl[j] + (self.wl[j + 1] - self.wl[j]) * k,
            self.wr[j] + (self.wr[j + 1] - self.wr[j]) * k,
        )
    }

    /// Arc length between parameters `ua <= ub` (5-point Gauss-Legendre), m.
    pub fn arc_length(&self, ua: f32, ub: f32) -> f32 {
        let half = 0.5 * (ub - ua);
        let mid = 0.5 * (ub + ua);
        GL5_NODES
            .iter()
            .zip(GL5_WEIGHTS.iter())
            .map(|(x, w)| w * vt_fpu::norm(&self.eval(mid + half * x).1))
            .sum::<f32>()
            * half
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn straight_line_has_zero_curvature_and_unit_speed() {
        let s = Spline::<8>::new(&[Waypoint::new(0.0, 0.0, 1.0, 1.0), Waypoint::new(10.0, 0.0, 2.0, 1.0)])
            .unwrap();
        let (p, d1, d2) = s.eval(4.0);
        assert_relative_eq!(p, Vec2::new(4.0, 0.0), epsilon = 1e-5);
        assert_relative_eq!(d1, Vec2::new(1.0, 0.0), epsilon = 1e-5);
        assert_relative_eq!(d2.norm(), 0.0, epsilon = 1e-6);
        assert_relative_eq!(s.arc_length(0.0, 10.0), 10.0, epsilon = 1e-4);
        let (wl, wr) = s.widths(5.0);
        assert_relative_eq!(wl, 1.5, epsilon = 1e-6);
        assert_relative_eq!(wr, 1.0, epsilon = 1e-6);
    }

    #[test]
    fn interpolates_waypoints_with_natural_ends() {
        let wps = [
            Waypoint::new(0.0, 0.0, 1.0, 1.0),
            Waypoint::new(5.0, 2.0, 1.0, 1.0),
            Waypoint::new(10.0, 0.0, 1.0, 1.0),
            Waypoint::new(15.0, -1.0, 1.0, 1.0),
        ];
        let s = Spline::<8>::new(&wps).unwrap();
        for (i, w) in wps.iter().enumerate() {
            let (p, _, _) = s.eval(s.u[i]);
            assert_relative_eq!(p, w.pos_m, epsilon = 1e-4);
        }
        assert_relative_eq!(s.eval(0.0).2.norm(), 0.0, epsilon = 1e-5);
        assert_relative_eq!(s.eval(s.param_end()).2.norm(), 0.0, epsilon = 1e-5);
        // Second derivative continuous across an interior knot.
        let u1 = s.u[1];
        assert_relative_eq!(s.eval(u1 - 1e-3).2, s.eval(u1 + 1e-3).2, epsilon = 1e-2);
    }

    #[test]
    fn rejects_bad_waypoints() {
        let ok = Waypoint::new(0.0, 0.0, 1.0, 1.0);
        assert_eq!(Spline::<4>::new(&[ok]).unwrap_err(), TubeError::TooFewWaypoints);
        assert_eq!(
            Spline::<4>::new(&[ok, ok]).unwrap_err(),
            TubeError::CoincidentWaypoints { index: 1 }
        );
        assert_eq!(
            Spline::<4>::new(&[ok, Waypoint::new(f32::NAN, 1.0, 1.0, 1.0)]).unwrap_err(),
            TubeError::NonFinite { index: 1 }
        );
        assert_eq!(
            Spline::<4>::new(&[ok, Waypoint::new(1.0, 1.0, 0.0, 1.0)]).unwrap_err(),
            TubeError::NonPositiveWidth { index: 1 }
        );
        assert_eq!(
            Spline::<2>::new(&[ok, Waypoint::new(1.0, 0.0, 1.0, 1.0), Waypoint::new(2.0, 0.0, 1.0, 1.0)])
                .unwrap_err(),
            TubeError::TooManyWaypoints { capacity: 2 }
        );
    }
}
