//! Folding a sector scan into the grid for the flight MCU (issue 28's budget: 1 ms at 168 MHz,
//! 168 k Cortex-M4 instructions per 72-sector scan; docs/benchmarks.md has what it costs).
//!
//! A beam of MAVLink `OBSTACLE_DISTANCE` is a *sector*: its closest obstacle lies somewhere on
//! the sector's arc at the reported range. So, per usable sector (docs/design.md, "Tubes
//! generated in flight"):
//! - **free space is the sector itself**: every cell whose centre lies in the triangle of the
//!   sensor and the sector's two edges at range `r` gets one miss (within `r (1 - cos(w/2))` of
//!   the arc for width `w`: 1.4 cm at 15 m and 5 deg). For a `Hit(r)` the triangle stops half a
//!   cell diagonal short of `r`, so no cell that may hold the obstacle's surface is freed; a
//!   `Clear` sector is free out to the sensor's range. Beams are cut at the fold's free range
//!   ([`SectorFold`], OctoMap's `maxrange`). A scan that turns at most once has sectors that
//!   do not overlap: their triangles' union, the fan, is filled as one polygon row by row
//!   (`crate::fan`), each cell once, every run along a row four cells at a time: a few
//!   instructions a cell, where walking a ray cell by cell ([`crate::ray::traverse`]) costs
//!   over a hundred. Otherwise each triangle is rasterised on its own by scanlines along its
//!   major axis (rows when it points mostly east or west, columns otherwise), each line one
//!   contiguous run;
//! - **hits across the arc** within `spread_range_m`: [`arc_points`] points spread across the
//!   arc, half a cell apart, each marks its cell. Beyond that range the arc is metres wide
//!   (1.3 m at 15 m and 5 deg) and only the sector's centre is marked; a guess elsewhere would
//!   close passages the team sees open from nearer;
//! - a cell holding a hit of this scan is never freed by its misses (OctoMap's rule, as in
//!   [`LogOddsGrid::integrate`]): its value from before the scan is put back before the hits,
//!   and each hit cell gets one hit per sector that marks it.
//!
//! Folded one by one, cells on an edge shared by two sectors may get a miss from each (a cell's
//! centre exactly on an edge, or within rounding of it). Sectors wider than [`MAX_SECTOR_RAD`], or of zero width,
//! are not sectors: such a scan is folded ray by ray by [`LogOddsGrid::integrate`].

use crate::fan::Fan;
use crate::store::CellStore;
use crate::{lanes, IntegrateStats, LogOddsGrid, LogOddsParams, Return, Scan, Vec2, MAX_BEAMS};

/// Most points marked per sector across its arc.
pub const MAX_ARC_POINTS: usize = 6;
/// Widest sector folded as a sector, rad (a quarter turn: the scanline's cell runs rely on the
/// sector lying within 45 deg plus half its width of its scan axis).
pub const MAX_SECTOR_RAD: f32 = core::f32::consts::FRAC_PI_2;
/// Half a cell's diagonal, cells: a cell whose centre is this much nearer than a hit lies
/// wholly before it.
const HALF_DIAGONAL_CELLS: f32 = 0.7072;
/// Capacity of one scan's hit-cell list.
const MAX_HIT_CELLS: usize = MAX_BEAMS * MAX_ARC_POINTS;

/// Points marked across a sector's arc of `width_rad` at range `range_m` on `cell_m` cells:
/// enough that they are at most half a cell apart, so no cell the arc crosses deeply is
/// skipped (1 to [`MAX_ARC_POINTS`]); 1 beyond
/// `spread_range_m` (or for a non-finite figure).
pub fn arc_points(width_rad: f32, range_m: f32, cell_m: f32, spread_range_m: f32) -> usize {
    if !(range_m <= spread_range_m) {
        return 1;
    }
    let spread = 2.0 * libm::fabsf(width_rad) * range_m / cell_m;
    if spread.is_finite() && spread >= 1.0 {
        // `ceil` by truncation (spread >= 1): `libm::ceilf` is a library routine on the M4.
        let t = spread as usize;
        (t + usize::from((t as f32) < spread)).min(MAX_ARC_POINTS)
    } else {
        1
    }
}

/// How a sector scan is folded into the grid ([`LogOddsGrid::integrate_sectors`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SectorFold {
    /// Hits nearer than this mark their whole arc, farther ones its centre only, m (NaN: the
    /// centre only).
    pub spread_range_m: f32,
    /// Beams are inserted out to at most this range, m: OctoMap's `maxrange` (Hornung et al.
    /// 2013), where a longer beam's free space is cut and its hit dropped. The cost of a scan
    /// grows with its square (NaN: nothing is inserted).
    pub free_range_m: f32,
}

/// A sector's free space in grid coordinates (cells): the triangle of the apex `a` and the two
/// points at `radius` along the unit directions `lo` and `hi` (`hi` counter-clockwise of `lo`,
/// less than a quarter turn apart). It lies inside the circular sector, within
/// `radius (1 - cos(w / 2))` of its arc for width `w`: 0.014 m at 15 m and 5 deg.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sector {
    /// Apex (the sensor), cells.
    pub a: Vec2,
    /// First edge's direction, unit.
    pub lo: Vec2,
    /// Second edge's direction, unit, counter-clockwise of `lo`.
    pub hi: Vec2,
    /// Radius, cells.
    pub radius: f32,
}

/// Edges whose extent across the scanlines is below this are left to the scanline range,
/// cells (their slope along the lines would overflow).
const FLAT_EDGE_CELLS: f32 = 1e-6;

/// One side of a triangle walked along the scanlines: the bound it puts on `x + 0.5` at the
/// current line's centre and its change from line to line, cells.
#[derive(Clone, Copy)]
struct EdgeWalk {
    /// `x + 0.5` of the edge at the current scanline's centre, cells.
    x: f32,
    /// Change per scanline, cells.
    slope: f32,
}

impl EdgeWalk {
    /// The edge from `u` to `v`, at the centre `y0` of the first scanline.
    fn new(u: Vec2, v: Vec2, y0: f32) -> Self {
        let e = v - u;
        let slope = if libm::fabsf(e.y) > FLAT_EDGE_CELLS { e.x / e.y } else { 0.0 };
        Self { x: u.x + slope * (y0 - u.y) + 0.5, slope }
    }
}

impl Sector {
    /// Calls `run(start, step, count)` for each scanline's run of cells of a `w x h` grid whose
    /// centres lie in the sector's triangle (`start`: row-major index of the first, `step`: 1
    /// along a row or `w` along a column). Near-ties (a centre within rounding of an edge) may
    /// go either way. Nothing for a non-finite sector.
    ///
    /// Scanlines run along the triangle's major axis (rows when it points mostly east or west,
    /// columns otherwise), so a 5 deg sector has few of them: the per-line cost is paid
    /// `radius x |sin|` times, not `radius` times. The triangle is split at its middle corner
    /// (across the lines) into two parts, each bounded by one edge on either side, so a line
    /// costs two adds, two conversions and two clamps.
    #[inline(always)]
    pub(crate) fn for_each_run(&self, w: usize, h: usize, mut run: impl FnMut(usize, usize, usize)) {
        let Self { a, lo, hi, radius } = *self;
        if !(a.x.is_finite() && a.y.is_finite() && radius.is_finite() && radius > 0.0) || w == 0 || h == 0 {
            return;
        }
        let (p, q) = (a + lo * radius, a + hi * radius);
        let mid = lo + hi;
        let (a, p, q, lines, len, line_stride, step) = if libm::fabsf(mid.x) >= libm::fabsf(mid.y) {
            (a, p, q, h, w, w, 1)
        } else {
            let t = |v: Vec2| Vec2::new(v.y, v.x);
            (t(a), t(p), t(q), w, h, 1, w)
        };
        // Corners by the scanline coordinate: v0 lowest, v1 middle, v2 highest.
        let (mut v0, mut v1, mut v2) = (a, p, q);
        if v1.y < v0.y {
            core::mem::swap(&mut v0, &mut v1);
        }
        if v2.y < v1.y {
            core::mem::swap(&mut v1, &mut v2);
        }
        if v1.y < v0.y {
            core::mem::swap(&mut v0, &mut v1);
        }
        // Scanlines whose centre `k + 0.5` lies in [v0.y, v1.y) (lower part) and [v1.y, v2.y]
        // (upper part), inside the grid.
        let k0 = clamped_index(v0.y + 0.5, lines);
        let k1 = clamped_index(v1.y + 0.5, lines);
        let k2 = clamped_index(v2.y + 0.5, lines);
        if k2 <= k0 {
            return;
        }
        // The long edge v0 -> v2 bounds one side of both parts; v0 -> v1, then v1 -> v2, the
        // other. The long edge is on the left when it passes left of v1.
        let long = EdgeWalk::new(v0, v2, k0 as f32 + 0.5);
        let long_is_left = v0.x + long.slope * (v1.y - v0.y) < v1.x;
        let lower = EdgeWalk::new(v0, v1, k0 as f32 + 0.5);
        let (left, right) = if long_is_left { (long, lower) } else { (lower, long) };
        let n = len as i32;
        let (left, right) = scan_lines(k0, k1, left, right, line_stride, step, n, &mut run);
        let upper = EdgeWalk::new(v1, v2, k1 as f32 + 0.5);
        let (left, right) = if long_is_left { (left, upper) } else { (upper, right) };
        scan_lines(k1, k2, left, right, line_stride, step, n, &mut run);
    }
}

/// Scanlines `from..to` between the walks `left` and `right` (each holding `x + 0.5`): the cells
/// whose centre `i + 0.5` lies between the edges, `trunc(left) <= i < trunc(right)`, within
/// `0..n`. Returns the walks at line `to`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn scan_lines(
    from: usize,
    to: usize,
    mut left: EdgeWalk,
    mut right: EdgeWalk,
    line_stride: usize,
    step: usize,
    n: i32,
    run: &mut impl FnMut(usize, usize, usize),
) -> (EdgeWalk, EdgeWalk) {
    let mut start = from * line_stride;
    for _ in from..to {
        let i0 = (left.x as i32).clamp(0, n) as usize;
        let i1 = (right.x as i32).clamp(0, n) as usize;
        if i1 > i0 {
            run(start + i0 * step, step, i1 - i0);
        }
        start += line_stride;
        left.x += left.slope;
        right.x += right.slope;
    }
    (left, right)
}

/// `trunc(v)` clamped to `[0, n]` (NaN gives 0).
fn clamped_index(v: f32, n: usize) -> usize {
    if v >= 0.0 {
        (v as usize).min(n)
    } else {
        0
    }
}

impl<S: CellStore> LogOddsGrid<S> {
    /// Folds one sector scan into the grid (module doc); `on_new_occupied(i, j)` is called each
    /// time a cell goes from not occupied (log-odds <= 0) to occupied. Invalid `params` or
    /// scan geometry skip the whole scan, as in [`LogOddsGrid::integrate`]. A sensor outside
    /// the grid frees the part of its sectors inside it.
    ///
    /// Cost: per usable sector its scanlines (its extent across its major axis) and its cells
    /// (about `r^2 w / 2` cells for radius `r` and width `w`, in cells and radians), each a
    /// load, a saturating add and a store; at most [`MAX_ARC_POINTS`] hit cells.
    // Out of line: one call per scan, and the MCU profile (QEMU `-d exec`) can name it.
    #[inline(never)]
    pub fn integrate_sectors(
        &mut self,
        scan: &Scan,
        params: &LogOddsParams,
        fold: SectorFold,
        mut on_new_occupied: impl FnMut(usize, usize),
    ) -> IntegrateStats {
        let beams = scan.returns.len();
        if !self.cells.folds(params) || !scan.is_geometry_valid() {
            return IntegrateStats {
                beams_skipped: beams,
                ..IntegrateStats::default()
            };
        }
        let width_rad = libm::fabsf(scan.increment_rad);
        if !(width_rad > 0.0 && width_rad <= MAX_SECTOR_RAD) {
            return self.integrate(scan, params, on_new_occupied);
        }
        let mut stats = IntegrateStats::default();
        let a = self.to_grid(scan.origin_m);
        let res = self.resolution_m;
        // Each sector's first edge by rotation from the first one's (one sine and cosine of the
        // start and one of the increment per scan, in f32 ([`sin_cos`]: `libm`'s work in f64,
        // which the Cortex-M4F emulates in software); the rotation's rounding drifts by about
        // 1e-7 rad a step, 1e-5 rad over 72).
        let start = scan.first_angle_rad - 0.5 * width_rad;
        let (s_inc, c_inc) = sin_cos(scan.increment_rad);
        // The width is the increment's magnitude: the same cosine, the sine's magnitude.
        let (c_w, s_w) = (c_inc, libm::fabsf(s_inc));
        let (s0, c0) = sin_cos(start);
        let sectors = Sectors { scan, a, first_edge: Vec2::new(c0, s0), c_inc, s_inc, c_w, s_w, res, free_range_m: fold.free_range_m };
        // The hit cells and their values from before the scan (two arrays: 2.2 KB of stack
        // where `(u32, i8)` pairs took 3.5 KB).
        let mut hits: heapless::Vec<u32, MAX_HIT_CELLS> = heapless::Vec::new();
        let mut before_hits: heapless::Vec<i8, MAX_HIT_CELLS> = heapless::Vec::new();
        let (w, h) = (self.width, self.height);
        for slot in sectors.iter() {
            let Some(Usable { free: sector, hit_m: Some(r) }) = slot else {
                continue;
            };
            let m = arc_points(width_rad, r, res, fold.spread_range_m);
            let first = hits.len();
            let to_cells = r / res;
            for u in 0..m {
                // Spread across the arc by the normalised chord point (exact at the ends and the
                // centre; the spacing off the centre differs from uniform in angle by below
                // 0.1 % at 5 deg).
                let t = (u as f32 + 0.5) / m as f32;
                let chord = sector.lo * (1.0 - t) + sector.hi * t;
                let n = vt_fpu::norm(&chord);
                if !(n > 0.0) {
                    continue;
                }
                let Some(idx) = cell_index(a + chord * (to_cells / n), w, h) else {
                    continue;
                };
                let idx = idx as u32;
                if hits.get(first..).is_some_and(|own| own.contains(&idx)) {
                    continue;
                }
                let before = self.cells.get(idx as usize).unwrap_or(0);
                // Cannot fail: at most MAX_ARC_POINTS per sector, both alike.
                if hits.push(idx).is_ok() {
                    let _ = before_hits.push(before);
                }
            }
        }
        // Free space: the fan of the usable sectors, row by row (`crate::fan`), when they do
        // not overlap; otherwise each usable sector's cells.
        let (miss, floor) = (params.miss, params.min);
        for slot in sectors.iter() {
            if slot.is_some() {
                stats.beams_used += 1;
            } else {
                stats.beams_skipped += 1;
            }
        }
        let turned = width_rad * beams as f32;
        let fan_filled = turned <= core::f32::consts::TAU + FAN_CLOSE_RAD && {
            let fan = fan_of(&sectors, a, scan.increment_rad > 0.0, turned >= core::f32::consts::TAU - FAN_CLOSE_RAD);
            let cells = &mut self.cells;
            let updated = &mut stats.cells_updated;
            fan.fill(w, h, |start, count| {
                *updated += count;
                cells.miss_run(start, count, miss, floor);
            })
        };
        let one_by_one = if fan_filled { 0 } else { beams };
        for slot in sectors.iter().take(one_by_one) {
            let Some(Usable { free: sector, .. }) = slot else {
                continue;
            };
            let cells = &mut self.cells;
            let updated = &mut stats.cells_updated;
            sector.for_each_run(w, h, |start, step, count| {
                *updated += count;
                // Local copies: through the closure's references the compiler must reload
                // them after every cell store (an `i8` store may alias them).
                let (miss, floor) = (miss, floor);
                if step == 1 {
                    cells.miss_run(start, count, miss, floor);
                } else {
                    let mut idx = start;
                    for _ in 0..count {
                        if let Some(c) = cells.get(idx) {
                            cells.set(idx, lanes::miss_one(c, miss, floor));
                        }
                        idx += step;
                    }
                }
            });
        }
        // The hit cells as they were before the misses, then the hits.
        for (&idx, &before) in hits.iter().zip(&before_hits) {
            self.cells.set(idx as usize, before);
        }
        let width = self.width.max(1);
        for &idx in &hits {
            let idx = idx as usize;
            self.update(idx % width, idx / width, params.hit, params, &mut stats, &mut on_new_occupied);
        }
        stats
    }
}

/// A scan whose sectors turn within this of a full circle closes its fan (the far corners of
/// its last and first sectors are joined along their shared ray), rad; one that turns more
/// than a circle by more than this overlaps itself and is folded sector by sector. The
/// sectors' edges come by rotation in `f32`, which drifts by about 1e-5 rad over 72 sectors.
const FAN_CLOSE_RAD: f32 = 1e-3;

/// The fan of a scan's usable sectors (`crate::fan`): their far corners in the order the scan
/// turns (`ccw`: counter-clockwise), the sensor `a` between runs of them and, unless the scan
/// `closes` a full circle with both its end sectors usable, at the ends.
fn fan_of(sectors: &Sectors<'_>, a: Vec2, ccw: bool, closes: bool) -> Fan {
    let mut fan = Fan::new();
    let has_room = |u: Option<Option<Usable>>| u.flatten().is_some_and(|u| u.free.radius > 0.0);
    let closed = closes && has_room(sectors.iter().next()) && has_room(sectors.iter().last());
    if !closed {
        fan.push(a);
    }
    for slot in sectors.iter() {
        match slot {
            Some(Usable { free, .. }) if free.radius > 0.0 => {
                let (p, q) = (free.a + free.lo * free.radius, free.a + free.hi * free.radius);
                let (first, second) = if ccw { (p, q) } else { (q, p) };
                fan.push(first);
                fan.push(second);
            }
            _ => fan.push(a),
        }
    }
    if !closed {
        fan.push(a);
    }
    fan
}

/// A scan's sectors, made again for each pass over them rather than kept: the same rotations
/// in the same order give the same bits, and the flight MCU's map update needs 2.6 KiB less
/// stack (docs/benchmarks.md).
#[derive(Clone, Copy)]
struct Sectors<'s> {
    scan: &'s Scan,
    /// The sensor, cells.
    a: Vec2,
    /// The first sector's first edge, unit.
    first_edge: Vec2,
    /// Cosine and sine of the increment (one sector to the next).
    c_inc: f32,
    s_inc: f32,
    /// Cosine and sine of the sector's width (its first edge to its second).
    c_w: f32,
    s_w: f32,
    /// Cell side, m.
    res: f32,
    /// The fold's free range, m.
    free_range_m: f32,
}

impl Sectors<'_> {
    /// Each beam's sector, in scan order: `None` for a beam with no usable return.
    fn iter(&self) -> impl Iterator<Item = Option<Usable>> + '_ {
        let mut edge = self.first_edge;
        self.scan.returns.iter().map(move |ret| {
            let lo = edge;
            edge = rotate(edge, self.c_inc, self.s_inc);
            let (range_m, hit_m) = match *ret {
                Return::Hit(r) if r > 0.0 && r <= self.scan.max_range_m => (r, Some(r)),
                Return::Clear => (self.scan.max_range_m, None),
                _ => return None,
            };
            // Free space out to the hit (less half a cell diagonal) or the range. A beam longer
            // than the fold's free range is cut there and its hit dropped, as OctoMap's
            // `maxrange` does: a far hit is a guess on an arc too wide to place it, and the free
            // space that would correct the guess stops short of it (a NaN free range inserts
            // nothing).
            let (radius, hit_m) = if range_m < self.free_range_m {
                (range_m / self.res - if hit_m.is_some() { HALF_DIAGONAL_CELLS } else { 0.0 }, hit_m)
            } else {
                (self.free_range_m / self.res, None)
            };
            let hi = rotate(lo, self.c_w, self.s_w);
            Some(Usable { free: Sector { a: self.a, lo, hi, radius }, hit_m })
        })
    }
}

/// One usable sector of a scan: its free space and, for a hit, the hit's range (m).
#[derive(Clone, Copy)]
struct Usable {
    /// The free space.
    free: Sector,
    /// The hit's range, m (`None`: `Clear`).
    hit_m: Option<f32>,
}

/// Row-major index of the cell holding grid point `g` in a `w x h` grid, if inside: `floor` as
/// [`crate::ray::cell_at`] takes it, by truncation (equal for the non-negative coordinates a cell
/// inside has; `libm::floorf` is a library routine on the Cortex-M4).
fn cell_index(g: Vec2, w: usize, h: usize) -> Option<usize> {
    let inside = |x: f32, n: usize| (x >= 0.0 && x < n as f32).then_some(x as usize);
    let (i, j) = (inside(g.x, w)?, inside(g.y, h)?);
    Some(j * w + i)
}

/// `(sin x, cos x)`: `vt_fpu::sin_cos` (within 2e-7 for `|x| <= 100`), `libm`'s beyond its
/// quarter-turn reduction (about 1e9 rad).
pub(crate) fn sin_cos(x: f32) -> (f32, f32) {
    vt_fpu::sin_cos(x).unwrap_or_else(|| (libm::sinf(x), libm::cosf(x)))
}

/// `v` turned counter-clockwise by the angle of cosine `c` and sine `s`.
fn rotate(v: Vec2, c: f32, s: f32) -> Vec2 {
    Vec2::new(v.x * c - v.y * s, v.x * s + v.y * c)
}

#[cfg(test)]
#[path = "sector_tests.rs"]
mod tests;
