//! Instruction counts of the onboard perception on the flight MCU's core (issue 28): one map
//! update per range scan (`Perception::integrate`) and one re-plan (`Perception::replan`),
//! under QEMU `-icount shift=0` (`vt-bench-perception`, feature `perception-bench`).
//!
//! The world is fixed here so the figures are comparable from build to build: the onboard
//! map's full capacity (70 x 30 m at 0.25 m, [`vt_companion::perception::MAP_CELLS`] cells),
//! eight pillars across it, and a straight tube through its middle that the pillar at
//! (25, 15) blocks. The team flies the tube's centre line from x = 3 to 40 m, one scan every
//! 0.5 m (72 sectors of 5 deg, 15 m, each sector the closest of rays 0.5 deg apart, as the
//! simulator's LiDAR and PX4's `OBSTACLE_DISTANCE` fill them); the map is re-planned on the
//! empty map first and again at the end, when it has seen the most.
//!
//! The perception state is about 182 KiB, more than the STM32F405's 128 KiB of SRAM: this
//! build links against the QEMU board's full 4 MiB (`memory-qemu-bench.x`). It measures
//! instructions, which do not depend on where the RAM is; it is not a flight layout. The state
//! lives in `static`s built in place from `const` placeholders, so the stack figure logged at
//! the end is the map update's and the re-plan's own.
//!
//! Logged (defmt), in SysTick ticks of 25 MHz (the host converts them with the boot
//! calibration): `perception bench: map update: N scans, mean T, max T ticks` and
//! `perception bench: replan K: T ticks, ok B, waypoints W`.

use static_cell::ConstStaticCell;
use vt_companion::perception::{Perception, PerceptionConfig, PlannerSpace};
use vt_companion::{CompanionTube, Vec3};
use vt_map::{Return, Scan, Vec2};
use vt_plan::PlanParams;
use vt_tube::Waypoint;

use crate::board;

/// Pillars `(x, y, radius)`, m.
const PILLARS: [(f32, f32, f32); 8] = [
    (15.0, 8.0, 1.5),
    (15.0, 22.0, 1.5),
    (25.0, 15.0, 2.0),
    (35.0, 6.0, 1.5),
    (35.0, 24.0, 1.5),
    (45.0, 15.0, 2.0),
    (55.0, 9.0, 1.5),
    (55.0, 21.0, 1.5),
];
/// Sectors per scan and their width, rad (72 x 5 deg).
const SECTORS: usize = 72;
/// Rays per sector (0.5 deg apart).
const RAYS_PER_SECTOR: usize = 10;
/// Sensor range, m.
const RANGE_M: f32 = 15.0;
/// Scans along the path (x = 3 m, 3.5 m, ... 40 m).
const SCANS: usize = 75;

// Built in place (`const` placeholders configured at run time): never on the stack.
static PERCEPTION: ConstStaticCell<Perception> = ConstStaticCell::new(Perception::placeholder());
static SPACE: ConstStaticCell<PlannerSpace> = ConstStaticCell::new(PlannerSpace::zeroed());
static TUBE: ConstStaticCell<CompanionTube> = ConstStaticCell::new(CompanionTube::placeholder());
static CHECK: ConstStaticCell<CompanionTube> = ConstStaticCell::new(CompanionTube::placeholder());
static GRID: ConstStaticCell<vt_companion::perception::OnboardMap> = ConstStaticCell::new(vt_companion::perception::OnboardMap::zeroed());

/// Range along the ray from `o` in direction `(c, s)` to the nearest pillar, m (`None`: none
/// within [`RANGE_M`]).
fn ray_range_m(o: Vec2, c: f32, s: f32) -> Option<f32> {
    let mut best: Option<f32> = None;
    for &(x, y, r) in &PILLARS {
        // |o + t d - p|^2 = r^2 with |d| = 1: t = b - sqrt(b^2 - (|o - p|^2 - r^2)).
        let (dx, dy) = (o.x - x, o.y - y);
        let b = -(dx * c + dy * s);
        let disc = b * b - (dx * dx + dy * dy - r * r);
        if disc < 0.0 {
            continue;
        }
        let t = b - libm::sqrtf(disc);
        if t > 0.0 && t <= RANGE_M && best.is_none_or(|v| t < v) {
            best = Some(t);
        }
    }
    best
}

/// The scan taken at `o`: each sector the closest of its rays.
fn scan_at(o: Vec2) -> Scan {
    let sector = 2.0 * core::f32::consts::PI / SECTORS as f32;
    let mut scan = Scan::new(o, 0.0, sector, RANGE_M);
    for k in 0..SECTORS {
        let mut closest: Option<f32> = None;
        for u in 0..RAYS_PER_SECTOR {
            let a = sector * (k as f32 - 0.5 + (u as f32 + 0.5) / RAYS_PER_SECTOR as f32);
            if let Some(t) = ray_range_m(o, libm::cosf(a), libm::sinf(a)) {
                closest = Some(closest.map_or(t, |v: f32| v.min(t)));
            }
        }
        let _ = scan.returns.push(closest.map_or(Return::Clear, Return::Hit));
    }
    scan
}

/// Times one re-plan from the load at `load` and logs it as re-plan `k`.
fn time_replan(p: &mut Perception, space: &mut PlannerSpace, check: &mut CompanionTube, tube: &CompanionTube, load: &Vec3, k: u32) {
    let t0 = board::cycles();
    let r = p.replan(tube, load, 0, space, check);
    let ticks = board::cycles().wrapping_sub(t0);
    let waypoints = r.as_ref().map_or(0, |t| t.waypoints.len());
    defmt::info!("perception bench: replan {=u32}: {=u32} ticks, ok {=bool}, waypoints {=usize}", k, ticks, r.is_ok(), waypoints);
}

/// Runs the measurements, logs them and ends the emulation.
pub fn run() -> ! {
    let _board = board::init();
    defmt::info!("vt-bench-perception {=str} on {=str}", env!("CARGO_PKG_VERSION"), board::NAME);
    board::boot_report();
    let cfg = PerceptionConfig {
        bounds_m: [0.0, 70.0, 0.0, 30.0],
        cell_m: 0.25,
        goal_m: [67.0, 15.0],
        replan_period_ms: 1000,
        plan: PlanParams::default(),
    };
    let p = PERCEPTION.take();
    if p.configure(cfg).is_err() {
        defmt::error!("perception bench: the world does not fit the map");
        board::reboot();
    }
    let tube = TUBE.take();
    let check = CHECK.take();
    if tube.rebuild(&[Waypoint::new(3.0, 15.0, 5.0, 5.0), Waypoint::new(67.0, 15.0, 5.0, 5.0)]).is_err() {
        defmt::error!("perception bench: the tube does not build");
        board::reboot();
    }
    let tube: &CompanionTube = tube;
    let space = SPACE.take();
    defmt::info!("perception bench: state {=usize} bytes", core::mem::size_of::<Perception>() + core::mem::size_of::<PlannerSpace>());
    let start = Vec3::new(3.0, 15.0, 3.0);
    time_replan(p, space, check, tube, &start, 0);
    let (mut sum, mut max) = (0u64, 0u32);
    let mut load = start;
    for k in 0..SCANS {
        let o = Vec2::new(3.0 + 0.5 * k as f32, 15.0);
        let scan = scan_at(o);
        let load_s = tube.locate(o, 0).map_or(0.0, |s| s.s_m);
        let t0 = board::cycles();
        p.integrate(&scan, Some(tube), load_s);
        let ticks = board::cycles().wrapping_sub(t0);
        sum += u64::from(ticks);
        max = max.max(ticks);
        load = Vec3::new(o.x, o.y, 3.0);
    }
    let mean = (sum / SCANS as u64) as u32;
    // The map's fold alone (no tube test of new cells): the same scans into a fresh grid.
    let grid = GRID.take();
    if grid.adopt(&vt_companion::perception::LOG_ODDS).is_ok() && grid.reset(280, 120, 0.25, Vec2::new(0.0, 0.0)).is_ok() {
        let (mut gsum, mut gmax, mut cells) = (0u64, 0u32, 0usize);
        for k in 0..SCANS {
            let scan = scan_at(Vec2::new(3.0 + 0.5 * k as f32, 15.0));
            let t0 = board::cycles();
            let st = grid.integrate_sectors(&scan, &vt_companion::perception::LOG_ODDS, vt_companion::perception::FOLD, |_, _| {});
            let ticks = board::cycles().wrapping_sub(t0);
            gsum += u64::from(ticks);
            gmax = gmax.max(ticks);
            cells += st.cells_updated;
        }
        // Synthetic scans at the map's middle (no tube test): every sector clear (the most free
        // space), every sector hit just short of the free range (the most free space and a hit
        // cell each) and every sector hit at 5.9 m (arcs of three cells).
        let mut synthetic = [0u32; 3];
        for (t, ret) in synthetic.iter_mut().zip([Return::Clear, Return::Hit(9.9), Return::Hit(5.9)]) {
            let mut scan = Scan::new(Vec2::new(35.0, 15.0), 0.0, 2.0 * core::f32::consts::PI / SECTORS as f32, RANGE_M);
            for _ in 0..SECTORS {
                let _ = scan.returns.push(ret);
            }
            let t0 = board::cycles();
            grid.integrate_sectors(&scan, &vt_companion::perception::LOG_ODDS, vt_companion::perception::FOLD, |_, _| {});
            *t = board::cycles().wrapping_sub(t0);
        }
        defmt::info!("perception bench: synthetic folds: clear {=u32}, far hits {=u32}, near hits {=u32} ticks", synthetic[0], synthetic[1], synthetic[2]);
        defmt::info!("perception bench: fold alone: mean {=u32}, max {=u32} ticks, {=usize} cells per scan", (gsum / SCANS as u64) as u32, gmax, cells / SCANS);
    }
    defmt::info!("perception bench: map update: {=usize} scans, mean {=u32}, max {=u32} ticks, blocked {=bool}", SCANS, mean, max, p.blocked());
    time_replan(p, space, check, tube, &load, 1);
    defmt::info!("perception bench: done; stack used {=u32} bytes", board::stack_used_bytes());
    board::shutdown()
}
