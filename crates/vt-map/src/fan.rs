//! A whole scan's free space as one polygon, filled row by row (the flight MCU's fold; issue
//! 28's budget of 168 k Cortex-M4 instructions per scan).
//!
//! The sectors of a scan that turns less than a full circle, or exactly one, do not overlap:
//! the union of their triangles is a *fan*, a polygon star-shaped around the sensor. Going round
//! it, each usable sector gives its two far corners, the boundary runs along the ray two
//! neighbours share from one's range to the other's, and a sector with no free space (unknown,
//! or a hit within half a cell's diagonal) sends it back to the sensor. Filling that polygon by
//! rows (the classic edge-table scan conversion: Foley et al., *Computer Graphics*, 2nd ed.,
//! 3.6) gives each cell whose centre it holds one miss, with every run along a row, where a
//! sector's triangle alone is filled along whichever axis it is longer on: a scanline per row
//! instead of one per sector and row, and four cells per instruction triple on every run
//! ([`crate::lanes`]). Scans whose sectors overlap (more than a turn) are folded sector by
//! sector, which counts a cell once per sector that holds it.

use crate::Vec2;

/// Most corners of a fan: two per sector, the sensor between runs of them, and the close.
pub(crate) const MAX_FAN_VERTICES: usize = 3 * crate::MAX_BEAMS + 2;
const _: () = assert!(MAX_FAN_VERTICES < u16::MAX as usize);
const _: () = assert!(MAX_FAN_ROWS < u16::MAX as usize);
/// Most rows a fan may span, cells (twice the free range at the resolution, plus two: 63 m of
/// free range at 0.25 m cells); a wider one is folded sector by sector.
pub(crate) const MAX_FAN_ROWS: usize = 512;

/// One edge of the fan while the rows are scanned: its `x + 0.5` at the current row's centre
/// and its change per row, cells, and the first row it no longer crosses (from the fan's
/// first row).
#[derive(Clone, Copy, Default)]
struct Edge {
    x: f32,
    dx: f32,
    end: u16,
}

/// The corners of a fan, in order round it, grid coordinates (cells).
pub(crate) struct Fan {
    corners: heapless::Vec<Vec2, MAX_FAN_VERTICES>,
}

impl Fan {
    /// A fan with no corner yet.
    pub(crate) fn new() -> Self {
        Self { corners: heapless::Vec::new() }
    }

    /// Appends a corner (ignored when the fan is full, which [`MAX_FAN_VERTICES`] rules out for
    /// a scan of at most `MAX_BEAMS` sectors; a repeat of the last corner adds nothing).
    pub(crate) fn push(&mut self, p: Vec2) {
        if self.corners.last() != Some(&p) {
            let _ = self.corners.push(p);
        }
    }

    /// Calls `run(start, count)` for each row's runs of cells of a `w x h` grid (row-major
    /// `start`) whose centres lie inside the polygon (even-odd rule; each edge holds the rows
    /// whose centre is in `(lower end, upper end]`, so a corner is counted once). Returns
    /// `false`, calling nothing, when the fan spans more than [`MAX_FAN_ROWS`] rows of the
    /// grid or a corner is not finite: fold it another way.
    pub(crate) fn fill(&self, w: usize, h: usize, mut run: impl FnMut(usize, usize)) -> bool {
        let n = self.corners.len();
        if n < 3 || w == 0 || h == 0 {
            return true;
        }
        let (mut y_lo, mut y_hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for c in &self.corners {
            if !(c.x.is_finite() && c.y.is_finite()) {
                return false;
            }
            y_lo = vt_fpu::min(y_lo, c.y);
            y_hi = vt_fpu::max(y_hi, c.y);
        }
        let row0 = row_at(y_lo, h);
        let row_end = row_at(y_hi, h);
        if row_end <= row0 {
            return true;
        }
        if row_end - row0 > MAX_FAN_ROWS {
            return false;
        }
        // The edge table: each edge filed under the first row it crosses (a counting sort).
        let mut edges = [Edge::default(); MAX_FAN_VERTICES];
        let mut first_row = [0u16; MAX_FAN_VERTICES];
        let mut filed = [0u16; MAX_FAN_VERTICES];
        let mut per_row = [0u16; MAX_FAN_ROWS];
        let mut count = 0usize;
        for k in 0..n {
            let (Some(&u), Some(&v)) = (self.corners.get(k), self.corners.get((k + 1) % n)) else {
                continue;
            };
            let (lo, hi) = if u.y <= v.y { (u, v) } else { (v, u) };
            let (r0, r1) = (row_at(lo.y, h), row_at(hi.y, h));
            if r1 <= r0 {
                continue;
            }
            let dx = (hi.x - lo.x) / (hi.y - lo.y);
            if let (Some(e), Some(f), Some(slot)) = (edges.get_mut(count), first_row.get_mut(count), per_row.get_mut(r0 - row0)) {
                *e = Edge { x: lo.x + dx * (r0 as f32 + 0.5 - lo.y) + 0.5, dx, end: (r1 - row0) as u16 };
                *f = (r0 - row0) as u16;
                *slot += 1;
                count += 1;
            }
        }
        // Counts to first slots, then each edge to its row's next slot: afterwards `per_row[r]`
        // is the end of row r's edges in `filed`, and the previous entry its start.
        let rows = row_end - row0;
        let mut acc = 0u16;
        for slot in per_row.iter_mut().take(rows) {
            let c = *slot;
            *slot = acc;
            acc += c;
        }
        for (e, &r) in first_row.iter().enumerate().take(count) {
            if let Some(at) = per_row.get_mut(usize::from(r)) {
                if let Some(slot) = filed.get_mut(usize::from(*at)) {
                    *slot = e as u16;
                }
                *at += 1;
            }
        }
        // The rows, with the edges that cross each (active), their crossings sorted.
        let mut active = [0u16; MAX_FAN_VERTICES];
        let mut n_active = 0usize;
        let mut xs = [0.0f32; MAX_FAN_VERTICES];
        let n_cols = w as i32;
        let mut start = row0 * w;
        for row in row0..row_end {
            let r = row - row0;
            let from = r.checked_sub(1).and_then(|p| per_row.get(p).copied()).unwrap_or(0);
            let to = per_row.get(r).copied().unwrap_or(0);
            for &e in filed.get(usize::from(from)..usize::from(to)).unwrap_or(&[]) {
                if let Some(slot) = active.get_mut(n_active) {
                    *slot = e;
                    n_active += 1;
                }
            }
            // Drop the edges that end here; collect the others' crossings, in order.
            let mut m = 0usize;
            let mut k = 0usize;
            while k < n_active {
                let e = active.get(k).copied().unwrap_or(0);
                let Some(edge) = edges.get_mut(usize::from(e)) else { break };
                if usize::from(edge.end) <= r {
                    n_active -= 1;
                    let last = active.get(n_active).copied().unwrap_or(0);
                    if let Some(slot) = active.get_mut(k) {
                        *slot = last;
                    }
                    continue;
                }
                let x = edge.x;
                edge.x += edge.dx;
                // Insertion into the sorted crossings (a row crosses few edges).
                let mut at = m;
                while let Some(&p) = at.checked_sub(1).and_then(|b| xs.get(b)).filter(|&&p| p > x) {
                    if let Some(slot) = xs.get_mut(at) {
                        *slot = p;
                    }
                    at -= 1;
                }
                if let Some(slot) = xs.get_mut(at) {
                    *slot = x;
                }
                m += 1;
                k += 1;
            }
            // Cells `trunc(x_a) <= i < trunc(x_b)` between each pair (the crossings hold x + 0.5).
            for pair in xs.get(..m).unwrap_or(&[]).chunks_exact(2) {
                if let [a, b] = *pair {
                    let i0 = (a as i32).clamp(0, n_cols) as usize;
                    let i1 = (b as i32).clamp(0, n_cols) as usize;
                    if i1 > i0 {
                        run(start + i0, i1 - i0);
                    }
                }
            }
            start += w;
        }
        true
    }
}

/// The first row whose centre `k + 0.5` lies above `y`, `trunc(y + 0.5)`, clamped to `[0, h]`
/// (NaN: 0): an edge holds the rows whose centre is in `(lower end, upper end]`.
fn row_at(y: f32, h: usize) -> usize {
    let v = y + 0.5;
    if v >= 0.0 {
        (v as usize).min(h)
    } else {
        0
    }
}
