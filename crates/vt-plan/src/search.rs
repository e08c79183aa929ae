//! Search over candidate disc centres: a square lattice, A* for the corridor and a widest-path
//! (maximin) search that names the narrowest passage when no corridor is wide enough.
//!
//! A node's value is its free-disc radius `r = min(clearance - margin, r_max)` (computed on
//! demand, so A* evaluates the map only where it looks). A node is usable when `r >= need`.
//! Edges join the 8 neighbours; an edge between usable nodes is at most `sqrt(2) h` long and
//! lies inside both discs when `h <= need` (checked by the planner).
//!
//! A* edge cost (a corridor-volume cost in the spirit of the authors' RRT* tube planner):
//! `len (1 + k_w (r_max / min(r_u, r_v) - 1))`, `k_w` = [`crate::PlanParams::clearance_weight`]:
//! narrow space costs more, so the path keeps to the middle of passages. The heuristic is the
//! Euclidean distance to the goal (admissible, the factor is >= 1). Ties are broken by node
//! index, so the result is deterministic.
#![allow(clippy::indexing_slicing)] // kernels only; every index is < Lattice::len() <= Workspace::capacity(), checked on entry

use crate::{ClearanceMap, PlanError, SweepSpace, Vec2};

/// A lattice node's index as the work space stores it (the heap and heap positions):
/// `u16` on the flight MCU (its 4,096 nodes in half the bytes), `u32` on the host.
pub trait NodeIndex: Copy + Ord + core::fmt::Debug {
    /// A node not in the open set.
    const NONE: Self;
    /// A node taken out of the open set for good.
    const CLOSED: Self;
    /// Nodes a work space of this index can hold (both marks stay above them).
    const CAPACITY: usize;
    /// Node `k`, below [`Self::CAPACITY`].
    fn from_node(k: usize) -> Self;
    /// The node this index names.
    fn node(self) -> usize;
}

macro_rules! node_index {
    ($t:ty) => {
        impl NodeIndex for $t {
            const NONE: Self = <$t>::MAX;
            const CLOSED: Self = <$t>::MAX - 1;
            const CAPACITY: usize = <$t>::MAX as usize - 2;
            #[inline]
            fn from_node(k: usize) -> Self {
                k as $t
            }
            #[inline]
            fn node(self) -> usize {
                self as usize
            }
        }
    };
}
node_index!(u16);
node_index!(u32);
node_index!(usize);

/// The 8 neighbour offsets and their lengths in lattice steps.
const NEIGHBOURS: [(i32, i32, f32); 8] = [
    (1, 0, 1.0),
    (-1, 0, 1.0),
    (0, 1, 1.0),
    (0, -1, 1.0),
    (1, 1, core::f32::consts::SQRT_2),
    (1, -1, core::f32::consts::SQRT_2),
    (-1, 1, core::f32::consts::SQRT_2),
    (-1, -1, core::f32::consts::SQRT_2),
];

/// A square lattice of candidate disc centres over the map rectangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattice {
    /// Node `(0, 0)`, m.
    pub origin_m: Vec2,
    /// Spacing `h`, m.
    pub spacing_m: f32,
    /// Columns.
    pub nx: usize,
    /// Rows.
    pub ny: usize,
}

impl Lattice {
    /// The lattice of spacing at least `spacing_m` covering `[min, max]`, coarsened until it has
    /// at most `capacity` nodes.
    ///
    /// # Errors
    /// [`PlanError::BadParams`] for a non-positive spacing or an empty rectangle.
    pub fn covering(min_m: Vec2, max_m: Vec2, spacing_m: f32, capacity: usize) -> Result<Self, PlanError> {
        if !(spacing_m > 0.0 && spacing_m.is_finite()) {
            return Err(PlanError::BadParams { field: "lattice_m" });
        }
        let size = max_m - min_m;
        if !(size.x > 0.0 && size.y > 0.0 && size.x.is_finite() && size.y.is_finite()) {
            return Err(PlanError::BadParams { field: "map bounds" });
        }
        let mut h = spacing_m;
        loop {
            let nx = (size.x / h) as usize + 1;
            let ny = (size.y / h) as usize + 1;
            match nx.checked_mul(ny) {
                Some(n) if n <= capacity => return Ok(Self { origin_m: min_m, spacing_m: h, nx, ny }),
                _ if capacity < 4 => return Err(PlanError::WorkspaceTooSmall { needed: 4 }),
                _ => h *= 1.05,
            }
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nx * self.ny
    }

    /// Whether the lattice has no node.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Position of node `k`, m.
    pub fn point_m(&self, k: usize) -> Vec2 {
        let (i, j) = (k % self.nx.max(1), k / self.nx.max(1));
        self.origin_m + Vec2::new(i as f32, j as f32) * self.spacing_m
    }

    /// The (up to 4) nodes of the lattice cell containing `p_m`, nearest first.
    pub fn around(&self, p_m: Vec2) -> [Option<usize>; 4] {
        let rel = (p_m - self.origin_m) / self.spacing_m;
        let fi = libm::floorf(rel.x).max(0.0) as usize;
        let fj = libm::floorf(rel.y).max(0.0) as usize;
        let mut out = [None; 4];
        let mut best = [f32::INFINITY; 4];
        for (di, dj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let (i, j) = (fi + di, fj + dj);
            if i >= self.nx || j >= self.ny {
                continue;
            }
            let k = j * self.nx + i;
            let d = (self.point_m(k) - p_m).norm_squared();
            // Insertion by distance, then index (deterministic).
            let mut slot = (k, d);
            for (o, b) in out.iter_mut().zip(best.iter_mut()) {
                let replace = match o {
                    None => true,
                    Some(ok) => slot.1 < *b || (slot.1 == *b && slot.0 < *ok),
                };
                if replace {
                    let prev = (*o, *b);
                    *o = Some(slot.0);
                    *b = slot.1;
                    match prev.0 {
                        Some(pk) => slot = (pk, prev.1),
                        None => break,
                    }
                }
            }
        }
        out
    }

    fn neighbour(&self, k: usize, di: i32, dj: i32) -> Option<usize> {
        let i = (k % self.nx) as i64 + i64::from(di);
        let j = (k / self.nx) as i64 + i64::from(dj);
        if i < 0 || j < 0 || i >= self.nx as i64 || j >= self.ny as i64 {
            None
        } else {
            Some(j as usize * self.nx + i as usize)
        }
    }
}

/// How a work space keeps a node's disc radius: `f32` as computed (the host), or `u8`, the
/// clearance rounded down to 1/254 of `max_radius + margin` (the flight MCU: 3 bytes a node
/// fewer; docs/planning.md, "Radii in a byte").
pub trait RadiusCell: Copy + core::fmt::Debug {
    /// A radius not computed yet.
    const UNKNOWN: Self;
    /// The cell of radius `r_m` (NaN-free) under `rule`'s margin and cap: never decodes above
    /// it, but below `-margin` (a clearance below 0, inside an obstacle), which decodes to
    /// `-margin`, blocked for every need.
    fn encode(r_m: f32, rule: &RadiusRule) -> Self;
    /// The radius, m (NaN: not computed).
    fn decode(self, rule: &RadiusRule) -> f32;
}

impl RadiusCell for f32 {
    const UNKNOWN: Self = f32::NAN;
    #[inline]
    fn encode(r_m: f32, _: &RadiusRule) -> Self {
        r_m
    }
    #[inline]
    fn decode(self, _: &RadiusRule) -> f32 {
        self
    }
}

/// Codes of a `u8` radius cell below [`RadiusCell::UNKNOWN`].
const BYTE_CODES: f32 = 254.0;

/// A `u8` cell's unit: `(max_radius + margin) / 254`, m.
#[inline]
fn byte_unit_m(rule: &RadiusRule) -> f32 {
    (rule.max_radius_m + rule.margin_m) * (1.0 / BYTE_CODES)
}

/// The radius a `u8` code stands for: `min(r_max, code unit - margin)`, m.
#[inline]
fn byte_radius_m(code: u8, rule: &RadiusRule) -> f32 {
    vt_fpu::min(rule.max_radius_m, f32::from(code) * byte_unit_m(rule) - rule.margin_m)
}

impl RadiusCell for u8 {
    const UNKNOWN: Self = u8::MAX;
    fn encode(r_m: f32, rule: &RadiusRule) -> Self {
        let unit = byte_unit_m(rule);
        let q = (r_m + rule.margin_m) / unit;
        // Below every code, or a degenerate unit: 0, the most blocked radius.
        if !(q > 0.0 && unit > 0.0 && unit.is_finite()) {
            return 0;
        }
        let mut code = if q >= BYTE_CODES { BYTE_CODES as u8 } else { q as u8 };
        // Rounded down, so a node is never wider than its clearance says.
        while code > 0 && byte_radius_m(code, rule) > r_m {
            code -= 1;
        }
        code
    }
    #[inline]
    fn decode(self, rule: &RadiusRule) -> f32 {
        if self == Self::UNKNOWN {
            f32::NAN
        } else {
            byte_radius_m(self, rule)
        }
    }
}

/// The planner's work space, borrowed from the caller: per lattice node a radius cell `R`,
/// 2 `f32` (a cost and a key; the key alone with [`Workspace::keys_only`]), 2 indices `I` and
/// half a byte ([`Workspace::parent_bytes`]).
#[derive(Debug)]
pub struct Workspace<'a, I: NodeIndex = u32, R: RadiusCell = f32> {
    radius: &'a mut [R],
    /// The rule the radii were encoded under (a `u8` cell's unit; kept radii share it).
    rule: RadiusRule,
    /// Each node's cost from the search's start; `None`: recovered as its key less the
    /// heuristic ([`Workspace::keys_only`]).
    cost: Option<&'a mut [f32]>,
    key: &'a mut [f32],
    /// The step that reached each node in the last search, two nodes a byte (node `2 m` in the
    /// low nibble of byte `m`): 0 for none, `d + 1` for `NEIGHBOURS[d]`. A step names the
    /// parent as well as its index would (the parent is the node one step back), in a quarter
    /// of a `u16`: 6 KiB less for the flight MCU's 4,096 nodes (docs/planning.md).
    steps: &'a mut [u8],
    heap: &'a mut [I],
    pos: &'a mut [I],
}

impl<'a, I: NodeIndex> Workspace<'a, I, f32> {
    /// Splits caller buffers: `floats` holds `3 capacity` values (the radii among them),
    /// `ints` `2 capacity` and `steps` [`Self::parent_bytes`]`(capacity)`.
    pub fn new(floats: &'a mut [f32], ints: &'a mut [I], steps: &'a mut [u8]) -> Self {
        let cap = floats.len() / 3;
        let (radius, rest) = floats.split_at_mut(cap);
        Self::with_radii(radius, rest, ints, steps)
    }
}

impl<'a, I: NodeIndex, R: RadiusCell> Workspace<'a, I, R> {
    /// Bytes of parent steps a work space of `nodes` nodes needs.
    pub const fn parent_bytes(nodes: usize) -> usize {
        nodes.div_ceil(2)
    }

    /// Splits caller buffers: `radii` holds `capacity` cells, `floats` `2 capacity` values,
    /// `ints` `2 capacity` and `steps` [`Self::parent_bytes`]`(capacity)`.
    pub fn with_radii(radii: &'a mut [R], floats: &'a mut [f32], ints: &'a mut [I], steps: &'a mut [u8]) -> Self {
        let cap = radii.len().min(floats.len() / 2).min(ints.len() / 2).min(steps.len().saturating_mul(2)).min(I::CAPACITY);
        let radius = radii.split_at_mut(cap).0;
        let (cost, rest) = floats.split_at_mut(cap);
        let key = rest.split_at_mut(cap).0;
        let (heap, rest) = ints.split_at_mut(cap);
        let pos = rest.split_at_mut(cap).0;
        let steps = steps.split_at_mut(Self::parent_bytes(cap)).0;
        Self::from_parts(radius, Some(cost), key, heap, pos, steps)
    }

    /// As [`Self::with_radii`] with one `f32` a node, `keys` (`capacity` long): a node's cost
    /// is its key less the heuristic, recomputed (a square root a pop, and one a relaxation
    /// of an open node), in 4 bytes a node less. Its searches put the heuristic and the edge
    /// costs on a grid of 2^-8 (`on_key_grid`), where the cost recovered is exact and ties
    /// stay ties: a path costs at most half a step of that grid an edge more.
    pub fn keys_only(radii: &'a mut [R], keys: &'a mut [f32], ints: &'a mut [I], steps: &'a mut [u8]) -> Self {
        let cap = radii.len().min(keys.len()).min(ints.len() / 2).min(steps.len().saturating_mul(2)).min(I::CAPACITY);
        let radius = radii.split_at_mut(cap).0;
        let key = keys.split_at_mut(cap).0;
        let (heap, rest) = ints.split_at_mut(cap);
        let pos = rest.split_at_mut(cap).0;
        let steps = steps.split_at_mut(Self::parent_bytes(cap)).0;
        Self::from_parts(radius, None, key, heap, pos, steps)
    }

    fn from_parts(radius: &'a mut [R], cost: Option<&'a mut [f32]>, key: &'a mut [f32], heap: &'a mut [I], pos: &'a mut [I], steps: &'a mut [u8]) -> Self {
        let rule = RadiusRule { margin_m: 0.0, max_radius_m: 0.0, need_m: 0.0, clearance_weight: 0.0 };
        Self { radius, rule, cost, key, steps, heap, pos }
    }

    /// Records that node `v` was reached by `NEIGHBOURS[d]` (a search's reset clears every step).
    #[inline]
    fn set_step(&mut self, v: usize, d: usize) {
        let code = (d + 1) as u8 & 0xF;
        if let Some(b) = self.steps.get_mut(v / 2) {
            *b = if v.is_multiple_of(2) { (*b & 0xF0) | code } else { (*b & 0x0F) | (code << 4) };
        }
    }

    /// The parent of node `v` in the last search on `lat` (`None` for none).
    pub(crate) fn parent(&self, lat: &Lattice, v: usize) -> Option<usize> {
        let b = self.steps.get(v / 2).copied()?;
        let code = if v.is_multiple_of(2) { b & 0x0F } else { b >> 4 };
        let (di, dj, _) = NEIGHBOURS.get(usize::from(code).checked_sub(1)?)?;
        lat.neighbour(v, -di, -dj)
    }

    /// Lattice nodes this work space can hold.
    pub fn capacity(&self) -> usize {
        self.radius.len()
    }

    /// Node `k`'s cached radius, m (NaN: not computed).
    #[inline]
    fn radius_at(&self, k: usize) -> f32 {
        self.radius[k].decode(&self.rule)
    }

    /// Clears the search state of the first `n` nodes; `keep_radii` keeps the cached radii.
    fn reset(&mut self, n: usize, keep_radii: bool) {
        if !keep_radii {
            self.radius[..n].fill(R::UNKNOWN);
        }
        if let Some(cost) = self.cost.as_deref_mut() {
            cost[..n].fill(f32::INFINITY);
        }
        self.key[..n].fill(f32::INFINITY);
        self.steps[..Self::parent_bytes(n)].fill(0);
        self.pos[..n].fill(I::NONE);
    }
}

/// What the searches need to know about the disc radii.
#[derive(Debug, Clone, Copy)]
pub struct RadiusRule {
    /// Margin subtracted from the clearance, m.
    pub margin_m: f32,
    /// Cap on a disc's radius, m.
    pub max_radius_m: f32,
    /// Radius a usable node needs, m.
    pub need_m: f32,
    /// Weight `k_w` of the clearance term in the edge cost.
    pub clearance_weight: f32,
}

impl RadiusRule {
    /// Free-disc radius at `p`: `min(clearance - margin, r_max)`, m.
    pub fn radius_m<M: ClearanceMap>(&self, map: &M, p_m: Vec2) -> f32 {
        self.radius_of_clearance_m(map.clearance_capped_m(p_m, self.max_radius_m + self.margin_m))
    }

    /// Free-disc radius where the clearance is `clearance_m`: `min(clearance - margin, r_max)`, m.
    fn radius_of_clearance_m(&self, clearance_m: f32) -> f32 {
        vt_fpu::min(self.max_radius_m, clearance_m - self.margin_m)
    }
}

/// Every node's disc radius from the map's lattice sweep, into the cache, when the map has one
/// ([`ClearanceMap::lattice_clearances_m`]); whether it did. The searches then read the cache
/// (`keep_radii`) and never query the map at a node.
pub(crate) fn sweep_radii<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(map: &M, lat: &Lattice, rule: &RadiusRule, ws: &mut Workspace<'_, I, R>) -> bool {
    let n = lat.len();
    if n > ws.capacity() {
        return false;
    }
    ws.rule = *rule;
    let Workspace { radius, cost, key, heap, pos, .. } = ws;
    let (below, above) = heap.split_at_mut(heap.len() / 2);
    // A NaN clearance (never from the maps here) counts as blocked, as in `radius_of`.
    let disc_of = |c: f32| {
        let v = rule.radius_of_clearance_m(c);
        if v.is_nan() { f32::NEG_INFINITY } else { v }
    };
    // The sweep works in the costs and the keys, or in the keys alone (two thirds as `V_y`
    // and heights, a third as the bounds); each clearance goes straight into its cell.
    let space = match cost {
        Some(cost) => SweepSpace { floats: cost, bounds: key, sites: pos, below, above },
        None => {
            let (floats, bounds) = key.split_at_mut(2 * key.len() / 3);
            SweepSpace { floats, bounds, sites: pos, below, above }
        }
    };
    let cells = &mut radius[..n];
    map.lattice_clearances_m(
        lat,
        &mut |k: usize, c: f32| {
            if let Some(cell) = cells.get_mut(k) {
                *cell = R::encode(disc_of(c), rule);
            }
        },
        space,
    )
}

/// Indexed binary min-heap over node keys, ties broken by node index.
struct Heap<'w, 'a, I: NodeIndex, R: RadiusCell> {
    ws: &'w mut Workspace<'a, I, R>,
    len: usize,
}

impl<I: NodeIndex, R: RadiusCell> Heap<'_, '_, I, R> {
    fn less(&self, a: I, b: I) -> bool {
        let (ka, kb) = (self.ws.key[a.node()], self.ws.key[b.node()]);
        ka < kb || (ka == kb && a < b)
    }

    fn swap(&mut self, i: usize, j: usize) {
        self.ws.heap.swap(i, j);
        let (a, b) = (self.ws.heap[i], self.ws.heap[j]);
        self.ws.pos[a.node()] = I::from_node(i);
        self.ws.pos[b.node()] = I::from_node(j);
    }

    fn up(&mut self, mut i: usize) {
        while i > 0 {
            let p = (i - 1) / 2;
            if self.less(self.ws.heap[i], self.ws.heap[p]) {
                self.swap(i, p);
                i = p;
            } else {
                break;
            }
        }
    }

    fn down(&mut self, mut i: usize) {
        loop {
            let (l, r) = (2 * i + 1, 2 * i + 2);
            let mut m = i;
            if l < self.len && self.less(self.ws.heap[l], self.ws.heap[m]) {
                m = l;
            }
            if r < self.len && self.less(self.ws.heap[r], self.ws.heap[m]) {
                m = r;
            }
            if m == i {
                break;
            }
            self.swap(i, m);
            i = m;
        }
    }

    /// Inserts `k` or lowers its key (the key is already written).
    fn push_or_decrease(&mut self, k: usize) {
        let p = self.ws.pos[k];
        if p == I::NONE {
            self.ws.heap[self.len] = I::from_node(k);
            self.ws.pos[k] = I::from_node(self.len);
            self.len += 1;
            self.up(self.len - 1);
        } else if p != I::CLOSED {
            self.up(p.node());
        }
    }

    fn pop(&mut self) -> Option<usize> {
        if self.len == 0 {
            return None;
        }
        let top = self.ws.heap[0].node();
        self.len -= 1;
        if self.len > 0 {
            self.swap(0, self.len);
            self.down(0);
        }
        self.ws.pos[top] = I::CLOSED;
        Some(top)
    }
}

fn radius_of<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(ws: &mut Workspace<'_, I, R>, lat: &Lattice, map: &M, rule: &RadiusRule, k: usize) -> f32 {
    let r = ws.radius_at(k);
    if r.is_nan() {
        let r = rule.radius_m(map, lat.point_m(k));
        // A NaN clearance (never from the maps here) counts as blocked.
        let r = if r.is_nan() { f32::NEG_INFINITY } else { r };
        let cell = R::encode(r, &ws.rule);
        ws.radius[k] = cell;
        cell.decode(&ws.rule)
    } else {
        r
    }
}

/// Cached disc radius of node `k` after a search (NaN if never evaluated).
pub(crate) fn cached_radius<I: NodeIndex, R: RadiusCell>(ws: &Workspace<'_, I, R>, k: usize) -> f32 {
    if k < ws.capacity() { ws.radius_at(k) } else { f32::NAN }
}

/// A search's start: the lattice checked against the work space, the search state cleared
/// (`keep_radii` keeps the cached radii); whether `from` is usable.
fn begin_search<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    lat: &Lattice,
    rule: &RadiusRule,
    ws: &mut Workspace<'_, I, R>,
    [from, to]: [usize; 2],
    keep_radii: bool,
) -> Result<bool, PlanError> {
    let n = lat.len();
    if n > ws.capacity() || from >= n || to >= n {
        return Err(PlanError::WorkspaceTooSmall { needed: n });
    }
    if !keep_radii {
        ws.rule = *rule;
    }
    ws.reset(n, keep_radii);
    Ok(radius_of(ws, lat, map, rule, from) >= rule.need_m)
}

/// Whether `to` can be reached from `from` over usable nodes (radius `>= rule.need_m`, the
/// 8-neighbourhood): what [`astar_cached`] would answer, by a flood fill with no costs and no
/// heap, on the radii in `ws` (`keep_radii` as there). Leaves the search state cleared for
/// the next search but for the marks it set.
///
/// # Errors
/// [`PlanError::WorkspaceTooSmall`] when the lattice exceeds the work space.
pub(crate) fn reachable<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    lat: &Lattice,
    rule: &RadiusRule,
    ws: &mut Workspace<'_, I, R>,
    from: usize,
    to: usize,
    keep_radii: bool,
) -> Result<bool, PlanError> {
    if !begin_search(map, lat, rule, ws, [from, to], keep_radii)? {
        return Ok(false);
    }
    // The queue in `heap` (every node enters once: it is marked as it enters), the marks in `pos`.
    ws.heap[0] = I::from_node(from);
    ws.pos[from] = I::CLOSED;
    let (mut head, mut tail) = (0usize, 1usize);
    while head < tail {
        let u = ws.heap[head].node();
        head += 1;
        if u == to {
            return Ok(true);
        }
        for (di, dj, _) in NEIGHBOURS {
            let Some(v) = lat.neighbour(u, di, dj) else { continue };
            if ws.pos[v] == I::CLOSED || radius_of(ws, lat, map, rule, v) < rule.need_m {
                continue;
            }
            ws.pos[v] = I::CLOSED;
            ws.heap[tail] = I::from_node(v);
            tail += 1;
        }
    }
    Ok(false)
}

/// A* from `from` to `to` over usable nodes. On success the parents lead from `to` back to
/// `from` (`from` has none); returns whether `to` was reached.
///
/// # Errors
/// [`PlanError::WorkspaceTooSmall`] when the lattice exceeds the work space.
pub fn astar<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    lat: &Lattice,
    rule: &RadiusRule,
    ws: &mut Workspace<'_, I, R>,
    from: usize,
    to: usize,
) -> Result<bool, PlanError> {
    astar_cached(map, lat, rule, ws, from, to, false)
}

/// [`astar`], keeping the disc radii a previous search on the same map, lattice and rule
/// (margin and cap; the need may differ) left in `ws` when `keep_radii`: the planner's
/// second pass and the narrowest-passage search reuse them.
pub(crate) fn astar_cached<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    lat: &Lattice,
    rule: &RadiusRule,
    ws: &mut Workspace<'_, I, R>,
    from: usize,
    to: usize,
    keep_radii: bool,
) -> Result<bool, PlanError> {
    if !begin_search(map, lat, rule, ws, [from, to], keep_radii)? {
        return Ok(false);
    }
    let goal = lat.point_m(to);
    let h = lat.spacing_m;
    // Without the costs, the heuristic and the edge costs on a grid of 2^-8 (`on_key_grid`), so
    // a key less its heuristic is its cost exactly, and ties stay ties.
    let quantize = ws.cost.is_none();
    let q = |x: f32| if quantize { on_key_grid(x) } else { x };
    let to_goal = |k: usize| q(vt_fpu::norm(&(lat.point_m(k) - goal)));
    if let Some(cost) = ws.cost.as_deref_mut() {
        cost[from] = 0.0;
    }
    ws.key[from] = to_goal(from);
    let mut heap = Heap { ws, len: 0 };
    heap.push_or_decrease(from);
    while let Some(u) = heap.pop() {
        if u == to {
            return Ok(true);
        }
        let ru = heap.ws.radius_at(u);
        // Kept, or the key less the heuristic (exactly 0 at the start).
        let gu = match heap.ws.cost.as_deref() {
            Some(cost) => cost[u],
            None => heap.ws.key[u] - to_goal(u),
        };
        for (d, &(di, dj, len)) in NEIGHBOURS.iter().enumerate() {
            let Some(v) = lat.neighbour(u, di, dj) else { continue };
            if heap.ws.pos[v] == I::CLOSED {
                continue;
            }
            let rv = radius_of(heap.ws, lat, map, rule, v);
            if rv < rule.need_m {
                continue;
            }
            let r_edge = vt_fpu::min(ru, rv);
            let cost = q(len * h * (1.0 + rule.clearance_weight * (rule.max_radius_m / r_edge - 1.0)));
            let g = gu + cost;
            // With the costs kept, a lower cost; without, a lower key (the same heuristic).
            let key = match heap.ws.cost.as_deref_mut() {
                Some(costs) if g < costs[v] => {
                    costs[v] = g;
                    g + to_goal(v)
                }
                Some(_) => continue,
                None => {
                    let k = g + to_goal(v);
                    if !(k < heap.ws.key[v]) {
                        continue;
                    }
                    k
                }
            };
            heap.ws.key[v] = key;
            heap.ws.set_step(v, d);
            heap.push_or_decrease(v);
        }
    }
    Ok(false)
}

/// `x` rounded to the nearest multiple of 2^-8 for `0 <= x < 2^15` (2^-7 up to 2^16; adding
/// and taking away 2^15, where an `f32`'s step is 2^-8): sums and differences of such values
/// below 2^16 are exact in `f32`, so a work space of keys alone ([`Workspace::keys_only`])
/// recovers each cost exactly and breaks ties as one that keeps them.
#[inline]
fn on_key_grid(x: f32) -> f32 {
    const SHIFT: f32 = 32_768.0;
    (x + SHIFT) - SHIFT
}

/// Widest path from `from` to `to` (maximises the smallest disc radius along the way, any
/// node allowed). Returns the narrowest node of that path and its radius, m: the bottleneck
/// no route can avoid.
///
/// # Errors
/// [`PlanError::WorkspaceTooSmall`] when the lattice exceeds the work space.
pub fn widest_path_bottleneck<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    lat: &Lattice,
    rule: &RadiusRule,
    ws: &mut Workspace<'_, I, R>,
    from: usize,
    to: usize,
) -> Result<(usize, f32), PlanError> {
    let n = lat.len();
    if n > ws.capacity() || from >= n || to >= n {
        return Err(PlanError::WorkspaceTooSmall { needed: n });
    }
    ws.reset(n, true);
    // key = -bottleneck (min-heap), cost = bottleneck (or none: -key, exact).
    let r0 = radius_of(ws, lat, map, rule, from);
    if let Some(cost) = ws.cost.as_deref_mut() {
        cost[from] = r0;
    }
    ws.key[from] = -r0;
    let mut heap = Heap { ws, len: 0 };
    heap.push_or_decrease(from);
    while let Some(u) = heap.pop() {
        if u == to {
            break;
        }
        let bu = match heap.ws.cost.as_deref() {
            Some(cost) => cost[u],
            None => -heap.ws.key[u],
        };
        for (d, &(di, dj, _)) in NEIGHBOURS.iter().enumerate() {
            let Some(v) = lat.neighbour(u, di, dj) else { continue };
            if heap.ws.pos[v] == I::CLOSED {
                continue;
            }
            let b = bu.min(radius_of(heap.ws, lat, map, rule, v));
            let better = match heap.ws.cost.as_deref_mut() {
                Some(cost) if cost[v] == f32::INFINITY || b > cost[v] => {
                    cost[v] = b;
                    true
                }
                Some(_) => false,
                None => heap.ws.key[v] == f32::INFINITY || -b < heap.ws.key[v],
            };
            if better {
                heap.ws.key[v] = -b;
                heap.ws.set_step(v, d);
                heap.push_or_decrease(v);
            }
        }
    }
    Ok(narrowest_on_path(ws, lat, to, n))
}

/// The narrowest passage between `from` and `to`: the widest-path bottleneck `b`
/// ([`widest_path_bottleneck`]), then located on the A* path over nodes with radius `>= b`
/// (which keeps to the middle of passages, so the reported node is where the route is
/// squeezed rather than any node that ties with it). Returns the node and its radius, m.
///
/// # Errors
/// [`PlanError::WorkspaceTooSmall`] when the lattice exceeds the work space.
pub fn narrowest_passage<M: ClearanceMap, I: NodeIndex, R: RadiusCell>(
    map: &M,
    lat: &Lattice,
    rule: &RadiusRule,
    ws: &mut Workspace<'_, I, R>,
    from: usize,
    to: usize,
) -> Result<(usize, f32), PlanError> {
    let (k, b) = widest_path_bottleneck(map, lat, rule, ws, from, to)?;
    if !b.is_finite() {
        return Ok((k, b));
    }
    let at_b = RadiusRule { need_m: b, ..*rule };
    if astar_cached(map, lat, &at_b, ws, from, to, true)? {
        Ok(narrowest_on_path(ws, lat, to, lat.len()))
    } else {
        Ok((k, b))
    }
}

/// Walks the parents back from `to`: the first node with the smallest radius.
fn narrowest_on_path<I: NodeIndex, R: RadiusCell>(ws: &Workspace<'_, I, R>, lat: &Lattice, to: usize, n: usize) -> (usize, f32) {
    let mut k = to;
    let mut worst = (to, ws.radius_at(to));
    for _ in 0..n {
        let r = ws.radius_at(k);
        if r < worst.1 {
            worst = (k, r);
        }
        match ws.parent(lat, k) {
            None => break,
            Some(p) => k = p,
        }
    }
    worst
}

#[cfg(test)]
#[path = "search_tests.rs"]
mod tests;
