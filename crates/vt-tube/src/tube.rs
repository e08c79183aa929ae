//! The virtual tube as an arc-length table, its validation, and the section lookup
//! `s(q) = argmin_s |q - gamma(s)|` (eq:1-6) with the section's tangent `t_c` (eq:1-7),
//! normal, curvature, half-width `r_t`, midpoint `m` and boundary distance `d_t` (REFERENCE §2).
//!
//! # Representation
//! The generator curve (a natural cubic spline through the waypoints, [`crate::spline`]) is
//! resampled at `N` points equally spaced in arc length. Between samples the curve is the
//! chord; tangent, curvature and widths are interpolated linearly. With the default 256
//! samples on a 60 m tube the chord error is below 1 mm for bend radii above 5 m.
//!
//! # Lookup cost
//! [`Tube::locate`] descends from a warm-start segment (the previous answer) to a local
//! minimum of the distance, then certifies it in O(1) with a per-sample radius computed at
//! construction: inside it, no other part of the curve can be closer (REFERENCE §2 validity:
//! curvature bound + separation of distant parts). Only when that fails does it fall back to
//! an exact search over 16 bounding circles. Along a trajectory the cost is O(1) amortised.

use crate::spline::{Spline, Waypoint};
use crate::{TubeError, Vec2};

/// Default number of arc-length samples (host and firmware use the same table size, so
/// software- and processor-in-the-loop runs compute identical commands).
pub const DEFAULT_SAMPLES: usize = 256;
/// Waypoint capacity of the spline used to build a tube.
pub const MAX_WAYPOINTS: usize = 64;
/// Bounding circles for the exact fallback search.
const CHUNKS: usize = 16;
/// Spline sub-intervals per piece when integrating arc length.
const ARC_SUBSTEPS: usize = 16;
/// Cross-section points tested by the self-overlap check sit this fraction inside the boundary.
const OVERLAP_PROBE_FRACTION: f32 = 0.99;

/// One arc-length sample of the tube.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TubeSample {
    /// Point on the generator curve `gamma(s)`, m.
    pub pos_m: Vec2,
    /// Unit tangent `t(s)`.
    pub tangent: Vec2,
    /// Signed curvature `kappa(s)`, 1/m (positive when turning left).
    pub curvature_pm: f32,
    /// Left half-width `w_L(s)`, m.
    pub w_left_m: f32,
    /// Right half-width `w_R(s)`, m.
    pub w_right_m: f32,
}

impl TubeSample {
    const ZERO: Self = Self {
        pos_m: Vec2::new(0.0, 0.0),
        tangent: Vec2::new(1.0, 0.0),
        curvature_pm: 0.0,
        w_left_m: 0.0,
        w_right_m: 0.0,
    };

    /// Unit normal `n(s)`: the tangent rotated +90 deg.
    #[inline]
    pub fn normal(&self) -> Vec2 {
        Vec2::new(-self.tangent.y, self.tangent.x)
    }

    /// Left boundary point `gamma + w_L n`, m.
    pub fn left_boundary_m(&self) -> Vec2 {
        self.pos_m + self.normal() * self.w_left_m
    }

    /// Right boundary point `gamma - w_R n`, m.
    pub fn right_boundary_m(&self) -> Vec2 {
        self.pos_m - self.normal() * self.w_right_m
    }
}

/// The cross-section assigned to a point `q` (eq:1-6, eq:1-7, REFERENCE §2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// Arc length `s(q)` of the section, m.
    pub s_m: f32,
    /// Arc length left to the end terminal `L - s(q)`, m.
    pub remaining_m: f32,
    /// Segment index of the table: pass it back as the next lookup's warm start.
    pub segment: usize,
    /// Foot point `gamma(s(q))`, m.
    pub point_m: Vec2,
    /// Unit tangent `t_c(q)`.
    pub tangent: Vec2,
    /// Unit normal `n(s(q))` (tangent rotated +90 deg).
    pub normal: Vec2,
    /// Signed curvature `kappa(s(q))`, 1/m.
    pub curvature_pm: f32,
    /// Half-width `r_t = (w_L + w_R)/2`, m.
    pub half_width_m: f32,
    /// Midpoint `m = gamma + (w_L - w_R)/2 n`, m.
    pub midpoint_m: Vec2,
}

impl Section {
    /// Distance to the tube boundary `d_t = r_t - |q - m|`, m (negative outside).
    #[inline]
    pub fn boundary_distance_m(&self, q_m: Vec2) -> f32 {
        self.half_width_m - vt_fpu::norm(&(q_m - self.midpoint_m))
    }

    /// Signed lateral offset `(q - gamma) . n`, m (positive to the left).
    #[inline]
    pub fn lateral_offset_m(&self, q_m: Vec2) -> f32 {
        (q_m - self.point_m).dot(&self.normal)
    }
}

/// A validated virtual tube with `N` arc-length samples.
#[derive(Debug, Clone)]
pub struct Tube<const N: usize = DEFAULT_SAMPLES> {
    samples: [TubeSample; N],
    /// Radius around sample k within which a local distance minimum is the global one, m.
    certify_m: [f32; N],
    chunk_center_m: [Vec2; CHUNKS],
    chunk_radius_m: [f32; CHUNKS],
    chunk_len: usize,
    ds_m: f32,
    length_m: f32,
}

/// Squared distance from `q` to segment `a`-`b` and the clamped parameter along it.
#[inline]
fn segment_dist2(q: Vec2, a: Vec2, b: Vec2) -> (f32, f32) {
    let e = b - a;
    let len2 = e.norm_squared();
    let t = if len2 > 0.0 { ((q - a).dot(&e) / len2).clamp(0.0, 1.0) } else { 0.0 };
    ((q - (a + e * t)).norm_squared(), t)
}

impl<const N: usize> Tube<N> {
    /// Builds and validates a tube from waypoints (spline, arc-length resampling, checks).
    ///
    /// # Errors
    /// Any [`TubeError`]: bad waypoints, folding (`max(w_L, w_R) |kappa| >= 1`),
    /// overlapping terminals, or a self-overlapping tube.
    pub fn from_waypoints(waypoints: &[Waypoint]) -> Result<Self, TubeError> {
        let mut tube = Self::placeholder();
        tube.rebuild(waypoints)?;
        Ok(tube)
    }

    /// Storage for a tube not built yet, all zero bits (so a `static` of it costs no flash): it
    /// is not a valid tube (nothing was checked, no tangent is a unit vector); only
    /// [`Tube::rebuild`] makes it one. For firmware that keeps its tube in a `static` and builds
    /// it in place.
    pub const fn placeholder() -> Self {
        const { assert!(N >= 2 * CHUNKS, "a tube table needs at least 32 samples") };
        const UNSET: TubeSample = TubeSample {
            pos_m: Vec2::new(0.0, 0.0),
            tangent: Vec2::new(0.0, 0.0),
            curvature_pm: 0.0,
            w_left_m: 0.0,
            w_right_m: 0.0,
        };
        Self {
            samples: [UNSET; N],
            certify_m: [0.0; N],
            chunk_center_m: [Vec2::new(0.0, 0.0); CHUNKS],
            chunk_radius_m: [0.0; CHUNKS],
            chunk_len: 0,
            ds_m: 0.0,
            length_m: 0.0,
        }
    }

    /// [`Tube::from_waypoints`] into this storage, without a second table on the stack (the
    /// tables are about 9 KiB at the default size).
    ///
    /// # Errors
    /// As [`Tube::from_waypoints`]; `self` is then not a valid tube (rebuild it before use).
    pub fn rebuild(&mut self, waypoints: &[Waypoint]) -> Result<(), TubeError> {
        let spline = Spline::<MAX_WAYPOINTS>::new(waypoints)?;
        self.chunk_len = (N - 1).div_ceil(CHUNKS);
        self.resample(&spline);
        self.check_folding()?;
        self.build_chunks();
        self.build_certification();
        self.check_terminals()?;
        self.check_self_overlap()
    }

    /// Fills the table with samples equally spaced in arc length.
    fn resample<const W: usize>(&mut self, spline: &Spline<W>) {
        let pieces = spline.len() - 1;
        let u_end = spline.param_end();
        let sub_du = |j: usize| (spline_knot(spline, j + 1) - spline_knot(spline, j)) / ARC_SUBSTEPS as f32;
        let mut total = 0.0;
        for j in 0..pieces {
            let du = sub_du(j);
            let u0 = spline_knot(spline, j);
            for k in 0..ARC_SUBSTEPS {
                let ua = u0 + du * k as f32;
                total += spline.arc_length(ua, ua + du);
            }
        }
        self.length_m = total;
        self.ds_m = total / (N - 1) as f32;
        let mut next = 0usize;
        let mut acc = 0.0f32;
        'outer: for j in 0..pieces {
            let du = sub_du(j);
            let u0 = spline_knot(spline, j);
            for k in 0..ARC_SUBSTEPS {
                let ua = u0 + du * k as f32;
                let ub = ua + du;
                let len = spline.arc_length(ua, ub);
                while next < N - 1 && (next as f32) * self.ds_m <= acc + len {
                    let want = next as f32 * self.ds_m - acc;
                    let mut u = ua + du * (want / len).clamp(0.0, 1.0);
                    // One Newton step on arc_length(ua, u) = want.
                    let speed = vt_fpu::norm(&spline.eval(u).1);
                    if speed > 0.0 {
                        u = crate::limit(u - (spline.arc_length(ua, u) - want) / speed, ua, ub);
                    }
                    self.set_sample(next, spline, u);
                    next += 1;
                }
                acc += len;
                if next >= N - 1 {
                    break 'outer;
                }
            }
        }
        while next < N {
            self.set_sample(next, spline, u_end);
            next += 1;
        }
    }

    fn set_sample<const W: usize>(&mut self, k: usize, spline: &Spline<W>, u: f32) {
        let (pos, d1, d2) = spline.eval(u);
        let speed = vt_fpu::norm(&d1);
        let (tangent, curvature) = if speed > 0.0 {
            (d1 / speed, (d1.x * d2.y - d1.y * d2.x) / (speed * speed * speed))
        } else {
            (Vec2::new(1.0, 0.0), 0.0)
        };
        let (wl, wr) = spline.widths(u);
        if let Some(slot) = self.samples.get_mut(k) {
            *slot = TubeSample { pos_m: pos, tangent, curvature_pm: curvature, w_left_m: wl, w_right_m: wr };
        }
    }

    fn check_folding(&self) -> Result<(), TubeError> {
        for (k, smp) in self.samples.iter().enumerate() {
            let ratio = smp.w_left_m.max(smp.w_right_m) * smp.curvature_pm.abs();
            if !(ratio < 1.0) {
                return Err(TubeError::Folding { s_m: k as f32 * self.ds_m, ratio });
            }
        }
        Ok(())
    }

    fn build_chunks(&mut self) {
        for c in 0..CHUNKS {
            let lo = (c * self.chunk_len).min(N - 1);
            let hi = ((c + 1) * self.chunk_len).min(N - 1);
            let pts = self.samples.get(lo..=hi).unwrap_or(&[]);
            let (mut min, mut max) = (Vec2::repeat(f32::MAX), Vec2::repeat(f32::MIN));
            for p in pts {
                min = min.inf(&p.pos_m);
                max = max.sup(&p.pos_m);
            }
            let center = (min + max) * 0.5;
            let radius = pts.iter().map(|p| vt_fpu::norm(&(p.pos_m - center))).fold(0.0f32, vt_fpu::max);
            if let (Some(cc), Some(cr)) = (self.chunk_center_m.get_mut(c), self.chunk_radius_m.get_mut(c)) {
                *cc = center;
                *cr = radius;
            }
        }
    }

    /// Certification radii: a local minimum at sample k with distance `d` below
    /// `certify_m[k]` is global. For a window of `w` samples either side (arc length at most
    /// `W = w ds`) with largest curvature `kappa_w` in it, the squared distance is convex along
    /// the window for `d + W < 1 / kappa_w` (every window point is within `d + W` of `q`, and
    /// the second derivative along `s` is `1 - kappa (q - gamma).n > 0`); points outside the
    /// window are at least `sep_w - d` away (`sep_w` the closest of them to sample k), which
    /// exceeds `d` when `d < sep_w / 2`. So `d < min(sep_w / 2, 1 / kappa_w - W)` certifies,
    /// for any `w`: the radius is the best over windows of 1, 2, 4, ... 64 samples (local
    /// curvature: wide on straight stretches, where the global bound `0.5 / kappa_max` was
    /// small). Two sample spacings are subtracted for the chord approximation.
    fn build_certification(&mut self) {
        /// Windows of 2^b samples either side, b < WINDOW_CLASSES (up to 64 samples, a quarter
        /// of the default table: wider windows cost more to build than they certify; measured
        /// in docs/benchmarks.md, "Onboard perception on the MCU core").
        const WINDOW_CLASSES: usize = 7;
        for k in 0..N {
            let pk = self.sample(k).pos_m;
            // Per class b < WINDOW_CLASSES: the closest sample with |j - k| in (2^(b-1), 2^b]
            // (class 0: |j - k| <= 1) and the largest curvature there; the last class is
            // everything farther, whose curvature no window needs.
            let mut sep2 = [f32::MAX; WINDOW_CLASSES + 1];
            let mut kappa = [0.0f32; WINDOW_CLASSES];
            for b in 0..=WINDOW_CLASSES {
                let (g0, g1) = match b {
                    0 => (0, 1),
                    _ if b < WINDOW_CLASSES => ((1usize << (b - 1)) + 1, 1usize << b),
                    _ => ((1usize << (WINDOW_CLASSES - 1)) + 1, N),
                };
                if g0 >= N {
                    break;
                }
                // Both sides of k: j in [k - g1, k - g0] and [k + g0, k + g1], inside the table.
                let below = k.checked_sub(g0).map(|hi| (k.saturating_sub(g1), hi));
                let above = (k + g0 < N).then(|| (k + g0, (k + g1).min(N - 1)));
                let bands = || below.into_iter().chain(above).flat_map(|(lo, hi)| self.samples.get(lo..=hi).unwrap_or(&[]));
                let d2 = if b == WINDOW_CLASSES {
                    self.closest_in_ranges2(pk, [below, above])
                } else {
                    bands().map(|smp| (smp.pos_m - pk).norm_squared()).fold(f32::MAX, vt_fpu::min)
                };
                if let Some(slot) = sep2.get_mut(b) {
                    *slot = d2;
                }
                if let Some(slot) = kappa.get_mut(b) {
                    *slot = bands().map(|smp| smp.curvature_pm.abs()).fold(0.0, vt_fpu::max);
                }
            }
            // Window b holds the classes <= b; the rest is outside it.
            let mut outside_of = [f32::MAX; WINDOW_CLASSES];
            let mut acc = f32::MAX;
            for b in (0..WINDOW_CLASSES).rev() {
                acc = vt_fpu::min(acc, sep2.get(b + 1).copied().unwrap_or(f32::MAX));
                if let Some(slot) = outside_of.get_mut(b) {
                    *slot = acc;
                }
            }
            let (mut best, mut kappa_w) = (0.0f32, 0.0f32);
            for b in 0..WINDOW_CLASSES {
                kappa_w = vt_fpu::max(kappa_w, kappa.get(b).copied().unwrap_or(f32::MAX));
                let w_m = (1usize << b) as f32 * self.ds_m;
                let sep2_b = outside_of.get(b).copied().unwrap_or(0.0);
                let sep_half = if sep2_b == f32::MAX { f32::MAX } else { 0.5 * vt_fpu::sqrt(sep2_b) };
                let convex = if kappa_w > 0.0 { 1.0 / kappa_w - w_m } else { f32::MAX };
                best = vt_fpu::max(best, vt_fpu::min(sep_half, convex));
            }
            let r = (best - 2.0 * self.ds_m).max(0.0);
            if let Some(slot) = self.certify_m.get_mut(k) {
                *slot = r;
            }
        }
    }

    /// The smallest squared distance from `p` to the samples of the index ranges (inclusive),
    /// `f32::MAX` for none: the same value as the exhaustive minimum, with chunks skipped whose
    /// bounding circle (padded by 1 mm against rounding) lies farther than the best so far.
    fn closest_in_ranges2(&self, p: Vec2, ranges: [Option<(usize, usize)>; 2]) -> f32 {
        let mut best = f32::MAX;
        // Outwards from the ranges' inner ends: the chunks nearest along the tube are usually
        // the nearest in the plane, so the farther ones are skipped.
        let start = ranges.iter().flatten().map(|&(lo, hi)| if lo == 0 { hi } else { lo }).next().unwrap_or(0);
        let c0 = (start / self.chunk_len.max(1)).min(CHUNKS - 1);
        let order = (0..2 * CHUNKS).filter_map(|i| if i % 2 == 0 { c0.checked_add(i / 2) } else { c0.checked_sub(i / 2 + 1) }).filter(|&c| c < CHUNKS);
        for c in order {
            let (c_lo, c_hi) = ((c * self.chunk_len).min(N - 1), ((c + 1) * self.chunk_len).min(N - 1));
            let parts = ranges.map(|r| r.map(|(lo, hi)| (lo.max(c_lo), hi.min(c_hi))).filter(|(lo, hi)| lo <= hi));
            if parts.iter().all(Option::is_none) {
                continue;
            }
            let gap = self.chunk_gap_m(c, p) - 1e-3;
            if gap > 0.0 && gap * gap > best {
                continue;
            }
            for (lo, hi) in parts.into_iter().flatten() {
                for smp in self.samples.get(lo..=hi).unwrap_or(&[]) {
                    best = vt_fpu::min(best, (smp.pos_m - p).norm_squared());
                }
            }
        }
        best
    }

    fn check_terminals(&self) -> Result<(), TubeError> {
        let a = self.sample(0);
        let b = self.sample(N - 1);
        if segments_intersect(a.left_boundary_m(), a.right_boundary_m(), b.left_boundary_m(), b.right_boundary_m()) {
            return Err(TubeError::OverlappingTerminals);
        }
        Ok(())
    }

    /// Every cross-section point must be assigned back to its own section.
    fn check_self_overlap(&self) -> Result<(), TubeError> {
        let tol = 2.0 * self.ds_m;
        for k in 0..N {
            let smp = self.sample(k);
            let n = smp.normal();
            for probe in [
                smp.pos_m + n * (smp.w_left_m * OVERLAP_PROBE_FRACTION),
                smp.pos_m - n * (smp.w_right_m * OVERLAP_PROBE_FRACTION),
            ] {
                let sec = self.locate_pruned(probe, k.min(N - 2));
                let s_k = k as f32 * self.ds_m;
                if (sec.s_m - s_k).abs() > tol {
                    // Endpoints: a probe beyond the terminal's section may legitimately map
                    // to the end sample itself; only distant assignments are overlaps.
                    return Err(TubeError::SelfOverlap { s_m: s_k });
                }
            }
        }
        Ok(())
    }

    /// Sample `k`, clamped into the table.
    #[inline]
    fn sample(&self, k: usize) -> TubeSample {
        self.samples.get(k.min(N - 1)).copied().unwrap_or(TubeSample::ZERO)
    }

    /// Squared distance from `q` to segment `k` (`k` in `0..N-1`) and the parameter on it.
    #[inline]
    fn seg(&self, q: Vec2, k: usize) -> (f32, f32) {
        segment_dist2(q, self.sample(k).pos_m, self.sample(k + 1).pos_m)
    }

    /// Total arc length `L`, m.
    pub fn length_m(&self) -> f32 {
        self.length_m
    }

    /// Sample spacing in arc length, m.
    pub fn ds_m(&self) -> f32 {
        self.ds_m
    }

    /// The arc-length samples (for plotting and inspection).
    pub fn samples(&self) -> &[TubeSample; N] {
        &self.samples
    }

    /// Largest `max(w_L, w_R) |kappa|` over the tube (< 1 for a valid tube).
    pub fn max_fold_ratio(&self) -> f32 {
        self.samples
            .iter()
            .map(|s| s.w_left_m.max(s.w_right_m) * s.curvature_pm.abs())
            .fold(0.0, f32::max)
    }

    /// Smallest half-width `r_t` along the tube, m.
    pub fn min_half_width_m(&self) -> f32 {
        self.samples.iter().map(|s| 0.5 * (s.w_left_m + s.w_right_m)).fold(f32::MAX, f32::min)
    }

    /// The radius within which [`Tube::locate`] takes a local minimum of the distance on
    /// segment `segment` (`0..N-1`) as the global one without searching, m: the smaller of the
    /// certification radii of the segment's two samples (0 past the table), as `locate` reads
    /// them. A caller that knows `q` is nearer to this segment than this radius, and not
    /// farther from it than from the neighbouring segments (in `locate`'s f32 arithmetic),
    /// knows that `locate(q, segment)` answers this segment (`vt-sim`'s clearances use it to
    /// skip lookups that cannot change).
    pub fn certified_radius_m(&self, segment: usize) -> f32 {
        vt_fpu::min(
            self.certify_m.get(segment).copied().unwrap_or(0.0),
            self.certify_m.get(segment + 1).copied().unwrap_or(0.0),
        )
    }

    /// Section of `q`, warm-started from segment `hint` (use the previous answer's
    /// [`Section::segment`]; any value is correct, a close one is fast).
    ///
    /// Returns `None` only for a non-finite `q`.
    pub fn locate(&self, q_m: Vec2, hint: usize) -> Option<Section> {
        if !vt_fpu::all_finite(&q_m) {
            return None;
        }
        let last_seg = N - 2;
        let mut k = hint.min(last_seg);
        let (mut best, mut t) = self.seg(q_m, k);
        let mut moved = false;
        while k < last_seg {
            let (d, tt) = self.seg(q_m, k + 1);
            if d < best {
                k += 1;
                best = d;
                t = tt;
                moved = true;
            } else {
                break;
            }
        }
        if !moved {
            while k > 0 {
                let (d, tt) = self.seg(q_m, k - 1);
                if d < best {
                    k -= 1;
                    best = d;
                    t = tt;
                } else {
                    break;
                }
            }
        }
        let cert = vt_fpu::min(
            self.certify_m.get(k).copied().unwrap_or(0.0),
            self.certify_m.get(k + 1).copied().unwrap_or(0.0),
        );
        if best <= cert * cert {
            return Some(self.section_at(k, t));
        }
        Some(self.search_chunks(q_m, k, best, t))
    }

    /// Section of `q` by exhaustive search over all segments (O(N); reference and tests).
    pub fn locate_exact(&self, q_m: Vec2) -> Section {
        let mut best = (f32::MAX, 0, 0.0);
        for k in 0..N - 1 {
            let (d, t) = self.seg(q_m, k);
            if d < best.0 {
                best = (d, k, t);
            }
        }
        self.section_at(best.1, best.2)
    }

    /// [`Tube::locate_exact`]'s section (the closest segment, the lowest index among equals),
    /// found with the chunks' bounding circles: seeded with segment `k0`, a chunk is skipped
    /// only when all of it is farther than the best so far by more than rounding (0.1 mm). The
    /// table's own check (`check_self_overlap`, 512 probes) costs a sixth of the exhaustive
    /// search on the flight MCU.
    fn locate_pruned(&self, q: Vec2, k0: usize) -> Section {
        let (mut best, mut bk, mut bt) = {
            let (d, t) = self.seg(q, k0);
            (d, k0, t)
        };
        for c in 0..CHUNKS {
            let gap = self.chunk_gap_m(c, q) - 1e-4;
            if gap > 0.0 && gap * gap > best {
                continue;
            }
            let lo = c * self.chunk_len;
            let hi = ((c + 1) * self.chunk_len).min(N - 1);
            for k in lo..hi {
                let (d, t) = self.seg(q, k);
                if d < best || (d == best && k < bk) {
                    best = d;
                    bk = k;
                    bt = t;
                }
            }
        }
        self.section_at(bk, bt)
    }

    /// How far `q` lies outside chunk `c`'s bounding circle, m (negative inside): no point of
    /// the chunk's samples or segments is nearer to `q`.
    #[inline]
    fn chunk_gap_m(&self, c: usize, q: Vec2) -> f32 {
        let center = self.chunk_center_m.get(c).copied().unwrap_or_else(Vec2::zeros);
        let radius = self.chunk_radius_m.get(c).copied().unwrap_or(f32::MAX);
        vt_fpu::norm(&(q - center)) - radius
    }

    /// Exact search pruned by bounding circles, seeded with a known candidate.
    fn search_chunks(&self, q: Vec2, k0: usize, d0: f32, t0: f32) -> Section {
        let (mut best, mut bk, mut bt) = (d0, k0, t0);
        for c in 0..CHUNKS {
            // Written out (not `chunk_gap_m`): this is the control step's fallback, and the helper
            // cost the MCU step 12 instructions here.
            let center = self.chunk_center_m.get(c).copied().unwrap_or_else(Vec2::zeros);
            let radius = self.chunk_radius_m.get(c).copied().unwrap_or(f32::MAX);
            let gap = vt_fpu::norm(&(q - center)) - radius;
            if gap > 0.0 && gap * gap >= best {
                continue;
            }
            let lo = c * self.chunk_len;
            let hi = ((c + 1) * self.chunk_len).min(N - 1);
            for k in lo..hi {
                let (d, t) = self.seg(q, k);
                if d < best {
                    best = d;
                    bk = k;
                    bt = t;
                }
            }
        }
        self.section_at(bk, bt)
    }

    /// Interpolated section at parameter `t` along segment `k`.
    #[inline]
    fn section_at(&self, k: usize, t: f32) -> Section {
        let a = self.sample(k);
        let b = self.sample(k + 1);
        let point = a.pos_m + (b.pos_m - a.pos_m) * t;
        let tan = a.tangent + (b.tangent - a.tangent) * t;
        let tn = vt_fpu::norm(&tan);
        let tangent = if tn > 0.0 { tan / tn } else { a.tangent };
        let normal = Vec2::new(-tangent.y, tangent.x);
        let wl = a.w_left_m + (b.w_left_m - a.w_left_m) * t;
        let wr = a.w_right_m + (b.w_right_m - a.w_right_m) * t;
        // `f32::min`/`max`'s values for every `t`, a NaN one included (the length first: it
        // is never NaN), without their calls to `fminf`/`fmaxf` on the Cortex-M4F.
        let s = vt_fpu::min(self.length_m, (k as f32 + t) * self.ds_m);
        Section {
            s_m: s,
            remaining_m: vt_fpu::max(0.0, self.length_m - s),
            segment: k,
            point_m: point,
            tangent,
            normal,
            curvature_pm: a.curvature_pm + (b.curvature_pm - a.curvature_pm) * t,
            half_width_m: 0.5 * (wl + wr),
            midpoint_m: point + normal * (0.5 * (wl - wr)),
        }
    }
}

/// Knot `j` of the spline's chord-length parameter.
#[inline]
fn spline_knot<const W: usize>(spline: &Spline<W>, j: usize) -> f32 {
    spline.knot(j)
}

/// True when closed segments `a0`-`a1` and `b0`-`b1` intersect.
fn segments_intersect(a0: Vec2, a1: Vec2, b0: Vec2, b1: Vec2) -> bool {
    let cross = |o: Vec2, p: Vec2, q: Vec2| (p.x - o.x) * (q.y - o.y) - (p.y - o.y) * (q.x - o.x);
    let d1 = cross(b0, b1, a0);
    let d2 = cross(b0, b1, a1);
    let d3 = cross(a0, a1, b0);
    let d4 = cross(a0, a1, b1);
    ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
}

#[cfg(test)]
#[path = "tube_tests.rs"]
mod tests;
