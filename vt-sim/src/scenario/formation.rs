//! The take-off formation (`[uavs] formation_radius_m` or `formation_offsets_m`): where each
//! UAV's node sits on the tray about the load when the team takes off. The springs' rest
//! lengths are the take-off distances (eq:2-7), so this is the formation the team flies, scaled
//! by the capacity-aware formation (`vt_dissipative::capacity`) and, in a passage, shaped to the
//! tube (`vt_dissipative::shape`). The companions read it from the take-off they measure; the
//! scenario's layout is where the operator puts the aircraft (docs/design.md, "Take-off
//! layouts other than the ring").

use super::validate::Validator;
use super::{Scenario, ScenarioError, SimTube, UavSpec};

/// How far apart two nodes of an explicit layout must be, m: closer, they are one place.
pub const MIN_NODE_SPACING_M: f64 = 1e-3;

impl UavSpec {
    /// The paper's ring's radius, m, when the scenario lays the team out on it
    /// (`formation_radius_m`); `None` for an explicit layout.
    pub fn ring_radius_m(&self) -> Option<f64> {
        if self.formation_offsets_m.is_some() { None } else { self.formation_radius_m }
    }

    /// Node offsets from the load on the tray at scale 1 for a team of `n`, m, in the tube's
    /// frame at the start (x along its direction, y to its left): node `i` of the ring at angle
    /// `2 pi i / n` (the take-off the paper's springs hold), or `formation_offsets_m` as given.
    pub fn formation_offsets(&self, n: usize) -> Vec<[f64; 2]> {
        match (&self.formation_offsets_m, self.formation_radius_m) {
            (Some(offsets), _) => offsets.clone(),
            (None, Some(r)) => (0..n)
                .map(|i| {
                    let a = std::f64::consts::TAU * i as f64 / n as f64;
                    [r * a.cos(), r * a.sin()]
                })
                .collect(),
            (None, None) => vec![[0.0, 0.0]; n],
        }
    }

    /// The take-off node farthest from the load, m: the ring's radius, or the largest offset.
    pub fn formation_reach_m(&self) -> f64 {
        match (&self.formation_offsets_m, self.formation_radius_m) {
            (Some(offsets), _) => offsets.iter().map(|d| d[0].hypot(d[1])).fold(0.0, f64::max),
            (None, r) => r.unwrap_or(0.0),
        }
    }
}

/// The first pair of `offsets` (m) closer than [`MIN_NODE_SPACING_M`], if any.
pub fn coincident_pair(offsets: &[[f64; 2]]) -> Option<(usize, usize)> {
    for (i, a) in offsets.iter().enumerate() {
        for (j, b) in offsets.iter().enumerate().skip(i + 1) {
            if (a[0] - b[0]).hypot(a[1] - b[1]) < MIN_NODE_SPACING_M {
                return Some((i, j));
            }
        }
    }
    None
}

/// The closest pair of UAVs where the plant starts them (m, centres; the UAVs' indices).
fn closest_takeoff_pair(s: &Scenario, tube: &SimTube) -> Option<(f64, usize, usize)> {
    let t = crate::sim::takeoff(s, tube, s.cables.rated_n);
    let mut closest: Option<(f64, usize, usize)> = None;
    for (i, a) in t.uav_pos_m.iter().enumerate() {
        for (j, b) in t.uav_pos_m.iter().enumerate().skip(i + 1) {
            let d = (a - b).norm();
            if closest.is_none_or(|c| d < c.0) {
                closest = Some((d, i, j));
            }
        }
    }
    closest
}

/// The smallest ring radius (m, to 1 cm, at most 4 times `radius_m`) whose take-off keeps every
/// pair `need_m` apart, for the error's hint; `None` when none does.
fn ring_radius_keeping(s: &Scenario, tube: &SimTube, radius_m: f64, need_m: f64) -> Option<f64> {
    let mut wide = s.clone();
    let mut apart = |r: f64| {
        wide.uavs.formation_radius_m = Some(r);
        closest_takeoff_pair(&wide, tube).is_none_or(|c| c.0 >= need_m)
    };
    let (mut lo, mut hi) = (radius_m, 4.0 * radius_m);
    if !apart(hi) {
        return None;
    }
    while hi - lo > 0.01 {
        let mid = 0.5 * (lo + hi);
        if apart(mid) { hi = mid } else { lo = mid }
    }
    Some(hi)
}

/// The field that lays the team out, for error locations.
pub(super) fn layout_field(s: &Scenario) -> &'static str {
    if s.uavs.formation_offsets_m.is_some() { "formation_offsets_m" } else { "formation_radius_m" }
}

impl Validator<'_> {
    /// One layout, well formed: the ring's radius or one finite offset per cable, no two nodes
    /// on one place, not every node on the load.
    pub(super) fn check_layout(&self, s: &Scenario) -> Result<(), ScenarioError> {
        match (&s.uavs.formation_offsets_m, s.uavs.formation_radius_m) {
            (Some(_), Some(_)) => Err(self.err("uavs", "formation_offsets_m", "give formation_radius_m (the ring) or formation_offsets_m (any layout), not both".into())),
            (None, None) => Err(self.err("uavs", "formation_radius_m", "missing: give formation_radius_m (the ring's radius, m) or formation_offsets_m (one [x, y] per cable, m)".into())),
            (None, Some(r)) => self.positive("uavs", "formation_radius_m", r),
            (Some(offsets), None) => {
                let n = s.cables.lengths_m.len();
                if offsets.len() != n {
                    return Err(self.err("uavs", "formation_offsets_m", format!("needs one [x, y] per cable: {n} (got {})", offsets.len())));
                }
                if let Some(i) = offsets.iter().position(|d| !(d[0].is_finite() && d[1].is_finite())) {
                    return Err(self.err("uavs", "formation_offsets_m", format!("UAV {i}'s offset is not finite")));
                }
                if let Some((i, j)) = coincident_pair(offsets) {
                    return Err(self.err("uavs", "formation_offsets_m", format!("UAVs {i} and {j} take off from the same node (closer than {MIN_NODE_SPACING_M} m)")));
                }
                if s.uavs.formation_reach_m() <= 0.0 {
                    return Err(self.err("uavs", "formation_offsets_m", "every node is on the load: the layout has no extent".into()));
                }
                Ok(())
            }
        }
    }

    /// With the clearances judged (`[mission] clearance_floor_m`), no two UAVs take off with their
    /// bodies closer than the floor: a formation that starts with its rotors within the floor
    /// flies so (its springs hold the take-off distances, eq:2-7), and failed every run of the
    /// 25-UAV team in the real-aircraft world (docs/design.md, "Take-off layouts other than the
    /// ring"). The places are those the plant starts in: hovering low over a ground start (the
    /// horizontal distance), taut in the air.
    pub(super) fn check_takeoff_bodies(&self, s: &Scenario, tube: &SimTube) -> Result<(), ScenarioError> {
        let Some(floor) = s.mission.clearance_floor_m else { return Ok(()) };
        let body = s.uavs.envelope_radius_m(s.uavs.model);
        if body <= 0.0 {
            return Ok(());
        }
        let need = 2.0 * body + floor;
        let Some((d, i, j)) = closest_takeoff_pair(s, tube) else { return Ok(()) };
        if d >= need {
            return Ok(());
        }
        let hint = match s.uavs.ring_radius_m() {
            Some(r) => match ring_radius_keeping(s, tube, r, need) {
                Some(wide) => format!("; a ring of {wide:.2} m keeps them apart, or lay a large team on two rings with formation_offsets_m"),
                None => "; lay the team on two rings with formation_offsets_m".to_string(),
            },
            None => "; spread the layout's nodes".to_string(),
        };
        Err(self.err("uavs", layout_field(s), format!(
            "UAVs {i} and {j} take off {d:.2} m apart (centres): their {body:.3} m bodies would be {:.2} m apart, under the clearance floor {floor} m{hint}",
            d - 2.0 * body)))
    }
}

#[cfg(test)]
mod tests {
    use super::super::{parse, PAPER_10UAV};
    use crate::sim::takeoff;

    /// The paper's ring given as explicit offsets (`formation_offsets_m`) starts every UAV where
    /// the ring does (the two paths of `sim::takeoff_with`), with the same capacity margin.
    #[test]
    fn the_ring_as_offsets_takes_off_where_the_ring_does() {
        let ring = parse(PAPER_10UAV, "ring.toml").expect("paper");
        let offsets: Vec<String> = ring.scenario.uavs.formation_offsets(10).iter().map(|d| format!("[{:.17e}, {:.17e}]", d[0], d[1])).collect();
        let text = PAPER_10UAV.replacen("formation_radius_m = 3.0", &format!("formation_offsets_m = [{}]", offsets.join(", ")), 1);
        let explicit = parse(&text, "offsets.toml").expect("the ring as offsets");
        let (a, b) = (takeoff(&ring.scenario, &ring.tube, 20.0), takeoff(&explicit.scenario, &explicit.tube, 20.0));
        for (i, (p, q)) in a.uav_pos_m.iter().zip(&b.uav_pos_m).enumerate() {
            assert!((p - q).norm() < 1e-9, "UAV {i}: {p:?} vs {q:?}");
        }
        assert!((a.capacity_margin - b.capacity_margin).abs() < 1e-12);
        assert!((explicit.scenario.uavs.formation_reach_m() - 3.0).abs() < 1e-12);
    }

    /// The 25-UAV team's two rings: every UAV takes off on its cable's line through its own node
    /// (the load, the node and the UAV in line, eq:2-4), at its taut length, and the inner ring's
    /// cables lean less than the outer's.
    #[test]
    fn each_uav_of_two_rings_takes_off_on_its_own_cable_line() {
        let text = include_str!("../../../scenarios/heavy-25uav.toml");
        let ls = parse(text, "heavy-25uav.toml").expect("shipped");
        let s = &ls.scenario;
        assert!(s.uavs.ring_radius_m().is_none());
        let t = takeoff(s, &ls.tube, s.cables.rated_n);
        let h = s.controller.tray_height_m;
        let mut leans = Vec::new();
        for (i, (p, q)) in t.uav_pos_m.iter().zip(&t.nodes_m).enumerate() {
            let rel = p - t.load_pos_m;
            let node = nalgebra::Vector3::new(q[0] - t.load_pos_m.x, q[1] - t.load_pos_m.y, h);
            assert!(rel.normalize().cross(&node.normalize()).norm() < 1e-9, "UAV {i} off its cable's line");
            let share = s.load.mass_kg * crate::plant::GRAVITY_MPS2 / 25.0 / (node.z / node.norm());
            let taut = s.cables.lengths_m[i] + share / s.cables.stiffness_n_per_m;
            assert!((rel.norm() - taut).abs() < 1e-9, "UAV {i}: {} m from the load, taut {taut} m", rel.norm());
            leans.push((node.xy().norm(), (rel.z / rel.norm()).acos()));
        }
        let inner = leans.iter().filter(|l| l.0 < 3.0).map(|l| l.1).fold(0.0, f64::max);
        let outer = leans.iter().filter(|l| l.0 > 4.9).map(|l| l.1).fold(f64::INFINITY, f64::min);
        assert!(inner < outer, "inner {inner} rad, outer {outer} rad");
        assert!((t.capacity_margin - 1.0).abs() < 1.0);
    }

    /// The host's take-off lean (`sim::takeoff_cos_lean`, the lean of its pre-flight and wind
    /// checks and of the generator's load sizing) is the one every companion measures when it
    /// calibrates on that take-off (`vt_dissipative::calibrate`, the mean over the cables), for
    /// the ring, two rings and a packed patch. On the packed patch the most leaning cable, the
    /// host's lean before session 54, is not it.
    #[test]
    fn the_host_s_take_off_lean_is_the_companions_calibration_s() {
        let packed = PAPER_10UAV.replacen(
            "formation_radius_m = 3.0",
            "formation_offsets_m = [[0.0, 1.912], [-1.296, 0.0], [-3.307, 0.0], [3.224, 0.0], [-2.264, -1.961], [2.206, 1.91], [-2.235, 1.935], [0.0, -2.067], [2.264, -1.961], [1.242, 0.0]]",
            1,
        );
        let cases = [
            (PAPER_10UAV.to_string(), "ring"),
            (include_str!("../../../scenarios/heavy-25uav.toml").to_string(), "two rings"),
            (packed, "packed"),
        ];
        for (text, name) in &cases {
            let ls = parse(text, name).expect("a shipped layout");
            let mut s = ls.scenario.clone();
            // The calibration measures the taut take-off (a ground start's, once the cables are taut).
            s.mission.start = crate::scenario::MissionStart::Air;
            let rated = s.cables.rated_n;
            let t = takeoff(&s, &ls.tube, rated);
            let f32v = |p: &nalgebra::Vector3<f64>| vt_companion::Vec3::new(p.x as f32, p.y as f32, p.z as f32);
            let uavs: Vec<vt_companion::Vec3> = t.uav_pos_m.iter().map(f32v).collect();
            let params = crate::companion::params_for(&s, 0, crate::sim::ControllerKind::Dissipative, rated, false).expect("mapped");
            let cal = vt_dissipative::calibrate(0, &uavs, &f32v(&t.load_pos_m), &params.calibration()).expect("calibrates");
            let host = crate::sim::takeoff_cos_lean(&s, rated);
            assert!((host - f64::from(cal.cos_lean)).abs() < 2e-6, "{name}: host {host}, companion {}", cal.cos_lean);
            let reach = s.uavs.formation_reach_m() * crate::sim::takeoff_scale(&s, rated);
            let h = s.controller.tray_height_m;
            let most_leaning = h / (h * h + reach * reach).sqrt();
            if *name == "packed" {
                assert!(host - most_leaning > 1e-3, "{name}: the mean {host} is the most leaning cable's {most_leaning}");
            }
        }
    }
}
