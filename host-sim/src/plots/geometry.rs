//! Geometry helpers shared by the views: bounds, equal-aspect fit, finite runs, thinning,
//! decimation, and the colours.

use super::*;

/// Axis-aligned box accumulated from finite points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Bounds {
    pub(crate) x0: f64,
    pub(crate) x1: f64,
    pub(crate) y0: f64,
    pub(crate) y1: f64,
}

impl Bounds {
    pub(crate) fn empty() -> Self {
        Self {
            x0: f64::INFINITY,
            x1: f64::NEG_INFINITY,
            y0: f64::INFINITY,
            y1: f64::NEG_INFINITY,
        }
    }
    pub(crate) fn add(&mut self, x: f64, y: f64) {
        if x.is_finite() && y.is_finite() {
            self.x0 = self.x0.min(x);
            self.x1 = self.x1.max(x);
            self.y0 = self.y0.min(y);
            self.y1 = self.y1.max(y);
        }
    }
    pub(crate) fn is_valid(&self) -> bool {
        self.x0.is_finite() && self.x1.is_finite() && self.y0.is_finite() && self.y1.is_finite()
    }
    /// Pads by `frac` of the larger side (at least `min_pad`); an empty box becomes [-1, 1]^2.
    pub(crate) fn padded(&self, frac: f64, min_pad: f64) -> Self {
        if !self.is_valid() {
            return Self {
                x0: -1.0,
                x1: 1.0,
                y0: -1.0,
                y1: 1.0,
            };
        }
        let p = ((self.x1 - self.x0).max(self.y1 - self.y0) * frac).max(min_pad);
        Self {
            x0: self.x0 - p,
            x1: self.x1 + p,
            y0: self.y0 - p,
            y1: self.y1 + p,
        }
    }
    /// Grows the short side so that a `pw` x `ph` pixel area has the same metres per pixel in x and y.
    pub(crate) fn fit_aspect(&self, pw: u32, ph: u32) -> Self {
        let (pw, ph) = (f64::from(pw.max(1)), f64::from(ph.max(1)));
        let (dx, dy) = ((self.x1 - self.x0).max(1e-9), (self.y1 - self.y0).max(1e-9));
        let scale = (dx / pw).max(dy / ph);
        let (cx, cy) = ((self.x0 + self.x1) / 2.0, (self.y0 + self.y1) / 2.0);
        let (hx, hy) = (scale * pw / 2.0, scale * ph / 2.0);
        Self {
            x0: cx - hx,
            x1: cx + hx,
            y0: cy - hy,
            y1: cy + hy,
        }
    }
}

pub(crate) fn top_view_bounds(scene: &SceneGeometry, recs: &[&RunRecord]) -> Bounds {
    let mut b = Bounds::empty();
    let [bx0, bx1, by0, by1] = scene.bounds_m;
    if bx1 > bx0 && by1 > by0 {
        b.add(bx0, by0);
        b.add(bx1, by1);
    }
    for line in [
        &scene.centerline,
        &scene.left_boundary,
        &scene.right_boundary,
    ] {
        for p in line {
            b.add(p[0], p[1]);
        }
    }
    for o in &scene.obstacles {
        if o.radius_m.is_finite() && o.radius_m >= 0.0 {
            b.add(o.center_m[0] - o.radius_m, o.center_m[1] - o.radius_m);
            b.add(o.center_m[0] + o.radius_m, o.center_m[1] + o.radius_m);
        }
    }
    for rec in recs {
        for p in &rec.load_pos_m {
            b.add(p[0], p[1]);
        }
        for p in rec.uav_pos_m.iter().flatten() {
            b.add(p[0], p[1]);
        }
    }
    b.padded(0.02, 0.5)
}

/// Figure size for `panels` top views side by side: the height follows the scene's aspect ratio.
pub(crate) fn top_view_size(b: &Bounds, panels: u32) -> (u32, u32) {
    let (w, plot_w, overhead) = if panels <= 1 {
        (1600, 1250.0, 150.0)
    } else {
        (2 * 1150 + LEGEND_W, 1030.0, 210.0)
    };
    let aspect = ((b.y1 - b.y0) / (b.x1 - b.x0).max(1e-9)).clamp(0.05, 20.0);
    // Clamped to a sane range before the (saturating) float-to-int cast.
    let h = (plot_w * aspect + overhead).clamp(450.0, 1500.0) as u32;
    (w, h)
}

/// Splits a point stream into runs of finite points (a line is broken at every NaN/inf).
pub(crate) fn finite_runs(points: impl IntoIterator<Item = (f64, f64)>) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut cur = Vec::new();
    for (x, y) in points {
        if x.is_finite() && y.is_finite() {
            cur.push((x, y));
        } else if !cur.is_empty() {
            runs.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        runs.push(cur);
    }
    runs
}

/// Drops points closer than `min_step` to the previously kept one (keeps the last point);
/// avoids ragged thick lines from many sub-pixel segments.
pub(crate) fn thin_out(run: Vec<(f64, f64)>, min_step: f64) -> Vec<(f64, f64)> {
    let last = run.last().copied();
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(run.len());
    for p in run {
        match out.last() {
            Some(q) if (p.0 - q.0).hypot(p.1 - q.1) < min_step => {}
            _ => out.push(p),
        }
    }
    if let (Some(l), Some(q)) = (last, out.last()) {
        if *q != l {
            out.push(l);
        }
    }
    out
}

pub(crate) fn circle_points(c: [f64; 2], r: f64) -> Vec<(f64, f64)> {
    (0..72)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::TAU / 72.0;
            (c[0] + r * a.cos(), c[1] + r * a.sin())
        })
        .collect()
}

pub(crate) fn n_uavs(rec: &RunRecord) -> usize {
    let pos = rec.uav_pos_m.iter().map(Vec::len).max().unwrap_or(0);
    let ten = rec.tension_n.iter().map(Vec::len).max().unwrap_or(0);
    pos.max(ten)
}

/// For long time series: keeps, per x bucket (`buckets` over `xr`), the first, lowest, highest
/// and last point in their original order, so peaks stay visible while drawing stays cheap.
pub(crate) fn min_max_decimate(run: Vec<(f64, f64)>, xr: Range<f64>, buckets: usize) -> Vec<(f64, f64)> {
    let width = xr.end - xr.start;
    if run.len() <= 4 * buckets || width.is_nan() || width <= 0.0 {
        return run;
    }
    let bucket_of = |x: f64| ((x - xr.start) / width * buckets as f64).floor() as i64;
    let mut out = Vec::with_capacity(4 * buckets + 4);
    let mut group: Vec<(usize, (f64, f64))> = Vec::with_capacity(4);
    let mut current = None;
    let flush = |group: &mut Vec<(usize, (f64, f64))>, out: &mut Vec<(f64, f64)>| {
        group.sort_by_key(|(k, _)| *k);
        group.dedup_by_key(|(k, _)| *k);
        out.extend(group.drain(..).map(|(_, p)| p));
    };
    let (mut lo, mut hi, mut last) = ((0, (0.0, 0.0)), (0, (0.0, 0.0)), (0, (0.0, 0.0)));
    for (k, p) in run.into_iter().enumerate() {
        let b = bucket_of(p.0);
        if current != Some(b) {
            if current.is_some() {
                group.extend([lo, hi, last]);
                flush(&mut group, &mut out);
            }
            current = Some(b);
            group.push((k, p));
            (lo, hi) = ((k, p), (k, p));
        }
        if p.1 < lo.1 .1 {
            lo = (k, p);
        }
        if p.1 > hi.1 .1 {
            hi = (k, p);
        }
        last = (k, p);
    }
    if current.is_some() {
        group.extend([lo, hi, last]);
        flush(&mut group, &mut out);
    }
    out
}

/// Distinct colour for UAV `i` (tab10, then a golden-ratio hue walk).
pub(crate) fn uav_color(i: usize) -> RGBColor {
    const TAB10: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    match TAB10.get(i) {
        Some(c) => *c,
        None => {
            let h = (i as f64 * 0.618_033_988_75).fract();
            let c = HSLColor(h, 0.7, 0.45).to_backend_color();
            RGBColor(c.rgb.0, c.rgb.1, c.rgb.2)
        }
    }
}

pub(crate) const BOUNDARY_COLOR: RGBColor = RGBColor(40, 55, 90);
pub(crate) const CENTERLINE_COLOR: RGBColor = RGBColor(150, 150, 150);
pub(crate) const OBSTACLE_FILL: RGBColor = RGBColor(175, 175, 175);
pub(crate) const OBSTACLE_EDGE: RGBColor = RGBColor(110, 110, 110);
pub(crate) const LOAD_COLOR: RGBColor = RGBColor(0, 0, 0);
