//! The UAV-boundary clearance without a section lookup at every sample (docs/design.md,
//! "Envelopes and clearances").
//!
//! The brute force locates every UAV in the tube at every plant step, warm-started from its
//! last segment (`Tube::locate(q, hint)`), and keeps the smallest `d_t(q) - r_u`. A sample may
//! be skipped when two things are certain: that the lookup would have answered the same
//! segment `k` (so the hint the brute force would carry is the one kept, and every later
//! lookup is the brute force's, bit for bit), and that the clearance it would have given is
//! above the running minimum (so the minimum is the brute force's, bit for bit). Both are
//! proved from the last measurement, the anchor, with bounds in exact arithmetic widened by
//! the f32 rounding of the lookup (derived below, then doubled).
//!
//! **The lookup stays on segment `k`** (crates/vt-tube/src/tube.rs, `Tube::locate`): from hint
//! `k` it moves to `k + 1` only if that segment's squared distance `d32(k+1) < d32(k)`, then to
//! `k - 1` only if `d32(k-1) < d32(k)`, and answers `k` without a search when
//! `d32(k) <= c_k^2` (`c_k = Tube::certified_radius_m(k)`). With `s` the coordinate of `q`
//! along segment `k` from its start `P_k` (length `E`), `c = (q - P_{k+1}) . t_{k+1}` and
//! `c' = (q - P_k) . t_{k-1}` (unit directions of the neighbours), in exact arithmetic
//! `d(k+1)^2 - d(k)^2 >= clamp(E - s, 0, E)^2 - max(c, 0)^2` and
//! `d(k-1)^2 - d(k)^2 >= clamp(s, 0, E)^2 - min(c', 0)^2` (Pythagoras on the feet; checked per
//! sample). The f32 distance `sqrt(d32)` is within `eps_d = u (9.1 D + 18 E + 1.42 X)` of the
//! exact one (`u = 2^-24`, `D` the distance, `E` the longest of the three segments, `X` the
//! largest coordinate of their ends: the rounded foot point `a + e t` carries `u X`, the
//! rounded parameter `t` at most `sqrt(3) E dt`). So the comparisons cannot go the wrong way
//! when `d(k±1) - d(k) >= 2 eps_d`, which holds when the squared margin `M` above satisfies
//! `M >= a^2` with `a = eps + sqrt(eps^2 + 4 eps D)` (from `d(k±1) - d(k) >= M / (2 D + sqrt M)`);
//! and the certificate holds while `D + eps_d <= c_k (1 - u)`, `D <= D_anchor + |q - q_anchor|`.
//!
//! **The clearance stays above the minimum.** On segment `k` the lookup's value is
//! `V(q) = r_t(t) - |q - m(t)|`, `t(q) = clamp((q - P_k) . e / E^2, 0, 1)` (1/E-Lipschitz), the
//! section point the projection `pi(q)` of `q` on the segment, `m = pi(q) + n(t) h(t)`,
//! `r_t = (w_L + w_R)/2` and `h = (w_L - w_R)/2` linear in `t`, `n` the normalised linear
//! blend of the end tangents. `q - pi(q)` is 1-Lipschitz (the residual of a projection on a
//! convex set), `|dn/dt| <= |t_b - t_a| / min_t |t_a + (t_b - t_a) t|`, so `V` is Lipschitz
//! with `L = 1 + (|dr_t| + |dh| + |t_b - t_a| H / u_min) / E` (`dr_t`, `dh` the changes over
//! the segment, `H` the larger `|h|` at its ends): it falls by at most `L |q - q_anchor|`.
//! The f32 value is within `eps_v = u (2.84 X + 47.1 W + 11.2 E + 8.2 D + 9.2 Lambda (1 + D/E))`
//! of `V` (`W` the largest width, `Lambda = (L - 1) E`), so a sample within
//! `(v_anchor - r_u - 2 eps_v - min) / L` of the anchor cannot lower the minimum.
//!
//! **Beyond the certified radius** the lookup searches the whole table and keeps `k` unless
//! some segment's `d32` is strictly smaller, so every other segment `j` must stay `2 eps_d`
//! farther. Along the tube away from `k`, `f(sigma) = |q - gamma(sigma)|^2` has slope 2 on
//! each segment, and at a vertex `P_v` its slope drops by at most `2 |P_v - q| b_v`
//! (`b_v = |t_v - t_{v-1}|`); on segment `k` the slope towards `P_{k+1}` is `2 (E - s) >= 0`
//! and `f(P_{k+1}) >= d(k)^2`, so beyond it `f - d(k)^2 >= h(tau) = tau^2 - 2 sum_v c_v
//! (tau - tau_v)+` (`tau` the arc length from `P_{k+1}`, `c_v` the bound of `|P_v - q| b_v`
//! over the reach). The least of `h` over the segments after `k + 1`, [`FOLLOW`] of them
//! (backward alike), must reach `a^2`; the segments more than [`SCAN_GAP`] from the scan's
//! own segment are scanned: at distance `far` from the scan's base, they stay apart while
//! `|q - q_anchor| <= (far - |q_anchor - base| - D) / 2 - eps`. Such a proof is made only for a
//! UAV whose lookup is not certified (its lookup searches the table, about ten times the cost
//! of a certified one), and its scan serves the UAV's next anchors while it proves as much.
//!
//! Everything the proof reads from the tube near the segment (the four samples' positions,
//! the segment's tangents and widths, its certified radius) is kept as bits and compared at
//! every skip, so the anchor is valid for any tube it is given: a re-planned tube
//! (`World::set_team_tube`), even one in the same memory, is measured anew unless it is the
//! same there. A proof beyond the certified radius reads every position: it also requires the
//! whole table's positions to be the ones it was made on ([`TubeSeen`], one comparison per
//! sample at most).

use crate::scenario::SimTube;

/// f32's unit roundoff `u = 2^-24`, doubled: the error bounds above are used twice over.
const U2: f64 = 2.0 / 16_777_216.0;
/// Absolute slack of the checks' own f64 arithmetic, m (far above its rounding at tube scale).
const SLACK_M: f64 = 1e-9;
/// How far beyond the segment's length a UAV may move from its anchor, m: farther it has left
/// the segment, so a larger reach would prove nothing and only widen the rounding bounds.
const REACH_M: f64 = 0.2;

type Xy = [f64; 2];

/// How many pairs of f32 values of the tube an anchor's lookup depends on (see [`window`]).
const WINDOW: usize = 9;

/// The bits of what `Tube::locate` from hint `k` and the boundary distance on segment `k` read
/// within the certified radius, two f32 to a word: the positions of samples `k - 1 ..= k + 2`
/// (zero where the table has none), the tangents and widths of samples `k`, `k + 1`, and the
/// segment's certified radius; `None` past the table.
fn window(tube: &SimTube, k: usize) -> Option<[u64; WINDOW]> {
    let s = tube.samples();
    let (a, b) = (s.get(k)?, s.get(k + 1)?);
    let pair = |x: f32, y: f32| u64::from(x.to_bits()) | (u64::from(y.to_bits()) << 32);
    let pos = |j: Option<usize>| j.and_then(|j| s.get(j)).map_or(0, |p| pair(p.pos_m.x, p.pos_m.y));
    Some([
        pos(k.checked_sub(1)),
        pair(a.pos_m.x, a.pos_m.y),
        pair(b.pos_m.x, b.pos_m.y),
        pos(Some(k + 2)),
        pair(a.tangent.x, a.tangent.y),
        pair(b.tangent.x, b.tangent.y),
        pair(a.w_left_m, a.w_right_m),
        pair(b.w_left_m, b.w_right_m),
        u64::from(tube.certified_radius_m(k).to_bits()),
    ])
}

fn sub(a: Xy, b: Xy) -> Xy {
    [a[0] - b[0], a[1] - b[1]]
}

fn dot(a: Xy, b: Xy) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

fn norm(a: Xy) -> f64 {
    dot(a, a).sqrt()
}

/// A sample's position, m, in f64 (exact).
fn pos(tube: &SimTube, k: usize) -> Option<Xy> {
    tube.samples().get(k).map(|s| [f64::from(s.pos_m.x), f64::from(s.pos_m.y)])
}

/// The unit direction and length (m) of segment `k`, if it is longer than a micrometre.
fn direction(tube: &SimTube, k: usize) -> Option<(Xy, f64)> {
    let e = sub(pos(tube, k + 1)?, pos(tube, k)?);
    let len = norm(e);
    (len > 1e-6 && len.is_finite()).then(|| ([e[0] / len, e[1] / len], len))
}

/// How many segments either side of the anchor's the far-reaching proof follows along the
/// tube (module docs): about 6 m of the paper's tube, where its bends keep the squared
/// distance rising.
const FOLLOW: usize = 32;
/// The segments either side of a scan's own segment it leaves out: within [`FOLLOW`] of every
/// segment up to this many away, so a scan serves the anchors of those segments too.
const SCAN_GAP: usize = FOLLOW / 2;

/// The sample positions of the tube the far-reaching anchors were made on, as bits, a count
/// of the tubes seen, and what the proofs need of the whole table: a whole-table comparison,
/// made at most once per sample and only when such an anchor is made or would skip.
#[derive(Debug, Clone, Default)]
pub(super) struct TubeSeen {
    positions: Vec<u64>,
    epoch: u64,
    checked: bool,
    /// Per segment, its unit direction and length, m (zero length: degenerate).
    dirs: Vec<(Xy, f64)>,
    /// The longest segment and the largest coordinate of the table, m.
    longest_m: f64,
    coords_m: f64,
}

/// A sample position's bits.
fn position_bits(s: &vt_tube::TubeSample) -> u64 {
    u64::from(s.pos_m.x.to_bits()) | (u64::from(s.pos_m.y.to_bits()) << 32)
}

impl TubeSeen {
    /// A new sample: the tube is not known to be the one seen.
    pub(super) fn new_sample(&mut self) {
        self.checked = false;
    }

    /// The epoch of `tube`: the one seen if its positions are, else a new one (and `tube`'s
    /// positions become the ones seen). Compares at most once per sample.
    fn epoch(&mut self, tube: &SimTube) -> u64 {
        if !self.checked {
            let table = tube.samples();
            let same = self.positions.len() == table.len() && table.iter().zip(&self.positions).all(|(s, b)| position_bits(s) == *b);
            if !same {
                self.positions.clear();
                self.positions.extend(table.iter().map(position_bits));
                self.epoch += 1;
                self.dirs.clear();
                self.dirs.extend((0..table.len() - 1).map(|k| direction(tube, k).unwrap_or(([0.0, 0.0], 0.0))));
                self.longest_m = self.dirs.iter().fold(0.0, |m, d| m.max(d.1));
                self.coords_m = table.iter().fold(0.0, |m, s| m.max(f64::from(s.pos_m.x).abs()).max(f64::from(s.pos_m.y).abs()));
            }
            self.checked = true;
        }
        self.epoch
    }

    /// Segment `k`'s unit direction and length (m), if not degenerate.
    fn dir(&self, k: usize) -> Option<(Xy, f64)> {
        self.dirs.get(k).copied().filter(|d| d.1 > 0.0)
    }

    /// The least of `h` (module docs) over the segments after the first when the tube is
    /// followed from vertex `first` (`forward`: vertices `first, first + 1, ...`, the segment
    /// after `P_v` is `v`; else `first, first - 1, ...`, the segment after `P_v` is `v - 1`)
    /// for `last - first` vertices, with `c_v = (|P_v - at| + reach) b_v` (m^2; `+inf` when no
    /// segment is after the first, `None` for a degenerate segment).
    fn rising_m2(&self, tube: &SimTube, first: usize, count: usize, forward: bool, at: Xy, reach: f64) -> Option<f64> {
        let (mut tau, mut c_sum, mut phi, mut least) = (0.0f64, 0.0f64, 0.0f64, f64::INFINITY);
        for i in 0..count {
            let v = if forward { first + i } else { first.checked_sub(i)? };
            let (before, after) = if forward { (v.checked_sub(1)?, v) } else { (v, v.checked_sub(1)?) };
            let ((t0, _), (t1, len)) = (self.dir(before)?, self.dir(after)?);
            let c = (norm(sub(pos(tube, v)?, at)) + reach) * norm(sub(t1, t0));
            c_sum += c;
            phi += c * tau;
            if i > 0 {
                // On this segment h = tau^2 - 2 C tau + 2 Phi, least at tau = C (clamped).
                let t = c_sum.clamp(tau, tau + len);
                least = least.min(t * t - 2.0 * c_sum * t + 2.0 * phi);
            }
            tau += len;
        }
        Some(least)
    }

    /// The exact distance (m) from `at` to the nearest segment more than [`SCAN_GAP`] from `k`.
    fn scan_m(&self, tube: &SimTube, k: usize, at: Xy) -> Option<f64> {
        let mut near2 = f64::INFINITY;
        for (j, &(dir, len)) in self.dirs.iter().enumerate() {
            if j.abs_diff(k) > SCAN_GAP {
                let w = sub(at, pos(tube, j)?);
                let t = dot(w, dir).clamp(0.0, len);
                let off = sub(w, [dir[0] * t, dir[1] * t]);
                near2 = near2.min(dot(off, off));
            }
        }
        Some(near2.sqrt())
    }
}

/// A scan's result kept for the next anchors of the same UAV: the distance (m) from `base` (m)
/// to the segments more than [`SCAN_GAP`] from `segment`, on the tube of `epoch`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Scan {
    epoch: u64,
    base: Xy,
    segment: usize,
    far_m: f64,
}

/// What the last measurement of one UAV's boundary clearance proves about the samples after
/// it (module docs).
#[derive(Debug, Clone, Copy)]
pub(super) struct BoundaryAnchor {
    /// The segment the lookup answered: the hint kept.
    segment: usize,
    /// [`window`] of the tube measured on.
    window: [u64; WINDOW],
    /// The [`TubeSeen`] epoch of the tube measured on when the proof reads all of it (beyond
    /// the certified radius); none when it reads only the window.
    epoch: Option<u64>,
    /// Where it was measured (the f32 position the lookup saw), m.
    at: Xy,
    /// A floor of the clearance there, m: `v - r_u - 2 eps_v`, less the checks' slack.
    floor_m: f64,
    /// `1 / L`, rounded down.
    inv_lipschitz: f64,
    /// The farthest a UAV may be from `at` and stay on the segment, m.
    reach_m: f64,
    /// Segment `k`'s start, m, unit direction and length, m.
    start: Xy,
    dir: Xy,
    len_m: f64,
    /// Segment `k + 1`'s start, m, and unit direction (none for the last segment).
    next_start: Xy,
    next_dir: Option<Xy>,
    /// Segment `k - 1`'s unit direction (none for the first segment).
    prev_dir: Option<Xy>,
    /// The squared margin `a^2` a neighbour must keep, m^2.
    margin_sq: f64,
    /// The last scan of the table (far-reaching proofs), for the next anchor.
    scan: Option<Scan>,
}

/// `eps_d` and the margin `a` for lookups with distances up to `d_cap`, segments up to
/// `longest` and coordinates up to `coords` (m; module docs: `eps_d` doubled, then `a`).
fn margin_m(d_cap: f64, longest: f64, coords: f64) -> (f64, f64) {
    let eps_d = U2 * (10.0 * d_cap + 20.0 * longest + 1.5 * coords) + 1e-12;
    let eps = eps_d / (1.0 - 10.0 * U2);
    (eps_d, (eps + (eps * eps + 4.0 * eps * d_cap).sqrt()) * (1.0 + 1e-9) + SLACK_M)
}

impl BoundaryAnchor {
    /// The anchor of a measurement: the lookup of the f32 position `q` (m) on `tube` answered
    /// `segment`, with boundary distance `value` (m); `r` is the envelope radius (m), `min_m`
    /// the running minimum after it (m), `scan` the UAV's last scan. `None` when it could
    /// prove nothing (its clearance is the minimum, or the geometry is degenerate).
    #[allow(clippy::too_many_arguments)] // one measurement's facts, named at the one call
    pub(super) fn new(tube: &SimTube, segment: usize, q: [f32; 2], value: f32, r: f64, min_m: f64, seen: &mut TubeSeen, scan: Option<Scan>) -> Option<Self> {
        // (A NaN value goes on, to fail `usable`.)
        if f64::from(value) - r <= min_m {
            return None;
        }
        let k = segment;
        let window = window(tube, k)?;
        let s = tube.samples();
        let (a, b) = (s.get(k)?, s.get(k + 1)?);
        let (dir, len) = direction(tube, k)?;
        let start = pos(tube, k)?;
        let next_start = pos(tube, k + 1)?;
        let next = if k + 2 < s.len() { Some(direction(tube, k + 1)?) } else { None };
        let prev = if k >= 1 { Some(direction(tube, k - 1)?) } else { None };
        let longest = [next, prev].into_iter().flatten().fold(len, |m, (_, l)| m.max(l));
        let coords = [k.checked_sub(1), Some(k), Some(k + 1), Some(k + 2)]
            .into_iter()
            .flatten()
            .filter_map(|j| pos(tube, j))
            .fold(0.0f64, |m, p| m.max(p[0].abs()).max(p[1].abs()));
        // Where the anchor is and what rounding its lookups may carry (module docs).
        let at = [f64::from(q[0]), f64::from(q[1])];
        let wq = sub(at, start);
        let along = dot(wq, dir);
        let across = wq[0] * dir[1] - wq[1] * dir[0];
        let off = along - along.clamp(0.0, len);
        let d_at = (across * across + off * off).sqrt() + SLACK_M;
        let reach_cap = len + REACH_M;
        let d_cap = d_at + reach_cap;
        let (eps_d, margin) = margin_m(d_cap, longest, coords);
        // Within the certified radius the lookup reads only the window.
        let cert_room = f64::from(tube.certified_radius_m(k)) * (1.0 - U2) - eps_d - d_at - SLACK_M;
        let mut anchor = Self {
            segment: k,
            window,
            epoch: None,
            at,
            floor_m: f64::NEG_INFINITY,
            inv_lipschitz: 0.0,
            reach_m: reach_cap.min(cert_room),
            start,
            dir,
            len_m: len,
            next_start,
            next_dir: next.map(|(d, _)| d),
            prev_dir: prev.map(|(d, _)| d),
            margin_sq: margin * margin,
            scan,
        };
        // Near a vertex (the lookup may have chosen either segment) the anchor proves nothing:
        // measured again at the next sample, it is not worth making.
        if !anchor.keeps_segment(at) {
            return None;
        }
        // The value's Lipschitz constant on the segment and its rounding (module docs).
        let w = |x: f32| f64::from(x);
        let (wla, wra, wlb, wrb) = (w(a.w_left_m), w(a.w_right_m), w(b.w_left_m), w(b.w_right_m));
        let widest = wla.abs().max(wra.abs()).max(wlb.abs()).max(wrb.abs());
        let ta = [w(a.tangent.x), w(a.tangent.y)];
        let dt = sub([w(b.tangent.x), w(b.tangent.y)], ta);
        let dt2 = dot(dt, dt);
        let tau = if dt2 > 0.0 { (-dot(ta, dt) / dt2).clamp(0.0, 1.0) } else { 0.0 };
        let u_min = norm([ta[0] + dt[0] * tau, ta[1] + dt[1] * tau]) * (1.0 - 1e-9);
        if u_min.is_nan() || u_min < 0.5 {
            return None;
        }
        let h_max = 0.5 * (wla - wra).abs().max((wlb - wrb).abs());
        let d_r = 0.5 * ((wlb + wrb) - (wla + wra)).abs();
        let d_h = 0.5 * ((wlb - wrb) - (wla - wra)).abs();
        let lambda = d_r + d_h + dt2.sqrt() * h_max / u_min;
        anchor.inv_lipschitz = 1.0 / ((1.0 + lambda / len) * (1.0 + 1e-9));
        let eps_v = U2 * (3.0 * coords + 48.0 * widest + 12.0 * len + 10.0 * d_cap + lambda * (10.0 + 5.0 * d_cap / len)) + 1e-12;
        anchor.floor_m = f64::from(value) - r - 2.0 * eps_v - SLACK_M;
        // Only a UAV the lookup does not certify (whose lookup searches the table) is worth
        // a proof that needs the whole table compared at every sample it skips.
        if cert_room <= 0.0 {
            let epoch = seen.epoch(tube);
            if let Some((reach, margin)) = anchor.far_reach(tube, seen, epoch, d_at, reach_cap) {
                (anchor.reach_m, anchor.margin_sq, anchor.epoch) = (reach, margin * margin, Some(epoch));
            }
        }
        let usable = anchor.reach_m > 0.0 && anchor.floor_m > min_m && anchor.inv_lipschitz > 0.0 && margin.is_finite();
        usable.then_some(anchor)
    }

    /// The UAV's last scan, for its next anchor.
    pub(super) fn scan(&self) -> Option<Scan> {
        self.scan
    }

    /// The far-reaching proof for this anchor, `d_at` (m) from its segment, for moves up to
    /// `reach_cap` (m): how far the UAV may move with every segment but `k` and its
    /// neighbours farther than `k` by the rounding margin and that margin `a` (m), or `None`
    /// (module docs). Reuses the UAV's last scan while it is of this tube,
    /// at most [`SCAN_GAP`] segments away, and still proves as much as a new one would.
    fn far_reach(&mut self, tube: &SimTube, seen: &TubeSeen, epoch: u64, d_at: f64, reach_cap: f64) -> Option<(f64, f64)> {
        let (k, at) = (self.segment, self.at);
        let n = tube.samples().len();
        let (_, margin) = margin_m(d_at + reach_cap, seen.longest_m, seen.coords_m);
        let eps = margin_m(d_at + reach_cap, seen.longest_m, seen.coords_m).0 / (1.0 - 10.0 * U2);
        // Followed: vertices k+1 ..= k+FOLLOW forward, k down to k-FOLLOW backward (within the
        // table); every segment more than SCAN_GAP away is scanned.
        let forward = seen.rising_m2(tube, k + 1, (n - 2).min(k + FOLLOW).saturating_sub(k), true, at, reach_cap)?;
        let backward = if k >= 1 { seen.rising_m2(tube, k, k.min(FOLLOW), false, at, reach_cap)? } else { f64::INFINITY };
        let rising = forward.min(backward);
        if rising.is_nan() || rising < margin * margin {
            return None;
        }
        // The scanned segments are at least `far - |at - base| - l` from the UAV after a move
        // `l`, the segment at most `d_at + l`: apart by `2 eps` while
        // `l <= (far - |at - base| - d_at) / 2 - eps`.
        let reach_of = |sc: &Scan| (sc.far_m - norm(sub(at, sc.base)) - d_at) * 0.5 - eps - SLACK_M;
        let reusable = self.scan.filter(|sc| sc.epoch == epoch && sc.segment.abs_diff(k) <= SCAN_GAP && reach_of(sc) >= reach_cap);
        let scan = match reusable {
            Some(sc) => sc,
            None => Scan { epoch, base: at, segment: k, far_m: seen.scan_m(tube, k, at)? },
        };
        self.scan = Some(scan);
        let reach = reach_cap.min(reach_of(&scan));
        (reach > 0.0).then_some((reach, margin))
    }

    /// True when the lookup of the f32 position `q` (m, as f64) on `tube` from this anchor's
    /// segment certainly answers that segment with a clearance above `min_m` (m): the sample
    /// changes neither the hint nor the minimum. False for a non-finite `q`.
    pub(super) fn skips(&self, q: Xy, min_m: f64, tube: &SimTube, seen: &mut TubeSeen) -> bool {
        let moved = sub(q, self.at);
        let budget = (self.floor_m - min_m) * self.inv_lipschitz;
        let reach = if budget >= self.reach_m { self.reach_m } else { budget };
        // Written so that NaN fails.
        if !(reach > 0.0 && dot(moved, moved) < reach * reach) {
            return false;
        }
        // The window compared word by word without a branch (an array `==` calls `bcmp`).
        let same = window(tube, self.segment).is_some_and(|w| w.iter().zip(&self.window).fold(0, |d, (a, b)| d | (a ^ b)) == 0);
        self.keeps_segment(q) && same && self.epoch.is_none_or(|e| seen.epoch(tube) == e)
    }

    /// True when the neighbouring segments are farther from `q` (m) than this one by the
    /// margin: `clamp(E - s, 0, E)^2 - max(c, 0)^2 >= a^2` and `clamp(s, 0, E)^2 - min(c', 0)^2
    /// >= a^2` (module docs; a negative clamp bound fails, as it must).
    fn keeps_segment(&self, q: Xy) -> bool {
        let wq = sub(q, self.start);
        let s = dot(wq, self.dir);
        if let Some(next) = self.next_dir {
            let c = dot(sub(q, self.next_start), next);
            let a = if s < 0.0 { self.len_m } else { self.len_m - s };
            if !(a > 0.0 && a * a - if c > 0.0 { c * c } else { 0.0 } >= self.margin_sq) {
                return false;
            }
        }
        if let Some(prev) = self.prev_dir {
            let c = dot(wq, prev);
            let a = if s > self.len_m { self.len_m } else { s };
            if !(a > 0.0 && a * a - if c < 0.0 { c * c } else { 0.0 } >= self.margin_sq) {
                return false;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_epoch_follows_the_positions_not_the_address() {
        let w = |x, y| vt_tube::Waypoint::new(x, y, 2.0, 2.0);
        let a = SimTube::from_waypoints(&[w(0.0, 0.0), w(10.0, 1.0), w(20.0, 0.0)]).unwrap();
        let b = SimTube::from_waypoints(&[w(0.0, 0.0), w(10.0, 1.0), w(20.0, 0.5)]).unwrap();
        let mut seen = TubeSeen::default();
        let first = seen.epoch(&a);
        // Within one sample the comparison is made once.
        assert_eq!(seen.epoch(&b), first);
        // A copy elsewhere in memory is the same tube; another one in the same box is not.
        seen.new_sample();
        assert_eq!(seen.epoch(&Box::new(a.clone())), first);
        let mut slot = Box::new(a.clone());
        seen.new_sample();
        assert_eq!(seen.epoch(&slot), first);
        *slot = b;
        seen.new_sample();
        let second = seen.epoch(&slot);
        assert_ne!(second, first);
        seen.new_sample();
        assert_ne!(seen.epoch(&a), second);
    }

    #[test]
    fn the_rising_bound_is_the_square_of_the_arc_on_a_straight_tube() {
        let w = |x| vt_tube::Waypoint::new(x, 0.0, 2.0, 2.0);
        let tube = SimTube::from_waypoints(&[w(0.0), w(25.5)]).unwrap();
        let mut seen = TubeSeen::default();
        seen.epoch(&tube);
        // No turn: h(tau) = tau^2, least at the start of the second segment followed.
        let h = seen.rising_m2(&tube, 11, 5, true, [1.0, 3.0], 0.3).unwrap();
        assert!((h - 0.01).abs() < 1e-7, "{h}");
        assert_eq!(seen.rising_m2(&tube, 11, 1, true, [1.0, 3.0], 0.3), Some(f64::INFINITY));
    }
}
