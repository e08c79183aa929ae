//! Validation of a parsed scenario: every field's range and the cross-field checks (tube
//! against obstacles, team against tube, rates, cable stiffness against the plant step), each
//! error naming the file, line and field.

use super::formation::layout_field;
use super::*;

pub(super) fn line_of_offset(text: &str, offset: usize) -> usize {
    text.get(..offset.min(text.len())).map_or(0, |t| t.matches('\n').count()) + 1
}

/// The field a `key = value` on 1-based `line` sets, as `table.key` (`faults[1].kind` in the
/// second `[[faults]]`), for parse errors; `None` on a line without a key.
pub(super) fn field_at_line(text: &str, line: usize) -> Option<String> {
    let lines: Vec<&str> = text.lines().collect();
    let here = lines.get(line.checked_sub(1)?)?.split('#').next().unwrap_or_default();
    let key = here.split_once('=')?.0.trim();
    if key.is_empty() || key.starts_with('[') {
        return None;
    }
    let header = lines.get(..line - 1)?.iter().rev().map(|l| l.split('#').next().unwrap_or_default().trim()).find(|l| l.starts_with('['));
    Some(match header {
        None => key.to_string(),
        Some(h) if h.starts_with("[[") => {
            let table = h.trim_matches(|c| c == '[' || c == ']').trim();
            let index = lines.get(..line - 1)?.iter().filter(|l| l.split('#').next().unwrap_or_default().trim() == h).count().saturating_sub(1);
            format!("{table}[{index}].{key}")
        }
        Some(h) => format!("{}.{key}", h.trim_matches(|c| c == '[' || c == ']').trim()),
    })
}

/// Finds the 1-based line of `key` inside table `table` (`""` for the top level).
fn line_of_key(text: &str, table: &str, key: &str) -> Option<usize> {
    let mut current = String::new();
    for (i, raw) in text.lines().enumerate() {
        // Without a trailing comment (`[controller]   # paper Table II`: issue 17 found that
        // fields of such tables got no line). A `#` inside a quoted value only cuts the value.
        let line = raw.split('#').next().unwrap_or_default().trim();
        if line.starts_with('[') {
            current = line.trim_matches(|c| c == '[' || c == ']').trim().to_string();
            continue;
        }
        if current == table {
            if let Some((k, _)) = line.split_once('=') {
                if k.trim() == key {
                    return Some(i + 1);
                }
            }
        }
    }
    // Arrays of tables and inline keys: fall back to the table header.
    text.lines()
        .position(|l| l.split('#').next().unwrap_or_default().trim().trim_matches(|c| c == '[' || c == ']').trim() == table)
        .map(|i| i + 1)
}

pub(super) struct Validator<'a> {
    pub(super) text: &'a str,
    pub(super) source_name: &'a str,
}

impl Validator<'_> {
    pub(super) fn err(&self, table: &str, key: &str, message: String) -> ScenarioError {
        let field = if table.is_empty() { key.to_string() } else { format!("{table}.{key}") };
        ScenarioError {
            source_name: self.source_name.into(),
            line: line_of_key(self.text, table, key),
            field: Some(field),
            message,
        }
    }

    pub(super) fn positive(&self, table: &str, key: &str, x: f64) -> Result<(), ScenarioError> {
        if x.is_finite() && x > 0.0 {
            Ok(())
        } else {
            Err(self.err(table, key, format!("must be a finite number > 0 (got {x})")))
        }
    }

    fn non_negative(&self, table: &str, key: &str, x: f64) -> Result<(), ScenarioError> {
        if x.is_finite() && x >= 0.0 {
            Ok(())
        } else {
            Err(self.err(table, key, format!("must be a finite number >= 0 (got {x})")))
        }
    }

    pub(super) fn check(&self, s: &Scenario) -> Result<SimTube, ScenarioError> {
        // World.
        let b = s.world.bounds_m;
        if !(b.iter().all(|x| x.is_finite()) && b[0] < b[1] && b[2] < b[3]) {
            return Err(self.err("world", "bounds_m", "must be finite [x_min, x_max, y_min, y_max] with min < max".into()));
        }
        self.positive("world", "ceiling_m", s.world.ceiling_m)?;
        for o in &s.world.obstacles {
            if !(o.center_m.iter().all(|x| x.is_finite())) {
                return Err(self.err("world.obstacles", "center_m", "must be finite".into()));
            }
            self.positive("world.obstacles", "radius_m", o.radius_m)?;
        }
        // Masses, thrust, cables.
        self.positive("load", "mass_kg", s.load.mass_kg)?;
        if let Some(m) = s.load.true_mass_kg {
            self.positive("load", "true_mass_kg", m)?;
        }
        self.positive("load", "altitude_m", s.load.altitude_m)?;
        if let Some(r) = s.load.radius_m {
            self.non_negative("load", "radius_m", r)?;
        }
        // An air start's load hangs above its resting altitude: the set-down's floor
        // (`VT_LOAD_GZ`, docs/design.md "In flight: the set-down").
        let rest = s.load.envelope_radius_m();
        if s.mission.start == crate::scenario::MissionStart::Air && s.load.altitude_m <= rest {
            return Err(self.err("load", "altitude_m", format!(
                "an air start needs the load above the ground: {} m is not above its resting altitude {rest:.2} m (its envelope radius)",
                s.load.altitude_m
            )));
        }
        self.non_negative("load", "start_s_m", s.load.start_s_m)?;
        self.positive("uavs", "mass_kg", s.uavs.mass_kg)?;
        self.positive("uavs", "thrust_max_n", s.uavs.thrust_max_n)?;
        self.non_negative("uavs", "thrust_lag_s", s.uavs.thrust_lag_s)?;
        if !(s.uavs.battery_sag_per_min.is_finite() && (0.0..=0.5).contains(&s.uavs.battery_sag_per_min)) {
            return Err(self.err("uavs", "battery_sag_per_min", format!("must be in [0, 0.5] per minute (got {})", s.uavs.battery_sag_per_min)));
        }
        // issue 17: the velocity loop needs the hover thrust m g within its limits
        // [0.05 thrust_max, thrust_max] (the companion's derived VL_T_MIN, vt_cfo::VelocityLoopParams::new, in
        // f32 as there); else the crate's error surfaced as a bare SimError with no location.
        let hover_n = s.uavs.mass_kg as f32 * vt_cfo::GRAVITY_MPS2;
        let thrust_max = s.uavs.thrust_max_n as f32;
        if hover_n > thrust_max {
            return Err(self.err("uavs", "thrust_max_n", format!("{} N cannot lift the UAV: its weight uavs.mass_kg * g is {hover_n} N", s.uavs.thrust_max_n)));
        }
        if hover_n < 0.05 * thrust_max {
            return Err(self.err("uavs", "mass_kg", format!("the UAV's weight {hover_n} N is below the minimum thrust 0.05 * uavs.thrust_max_n = {} N", 0.05 * thrust_max)));
        }
        if !(s.uavs.tilt_max_deg.is_finite() && s.uavs.tilt_max_deg > 0.0 && s.uavs.tilt_max_deg < 90.0) {
            return Err(self.err("uavs", "tilt_max_deg", format!("must be in (0, 90) degrees (got {})", s.uavs.tilt_max_deg)));
        }
        self.check_layout(s)?;
        if let Some(r) = s.uavs.body_radius_m {
            // The companion's VT_BODY_R range.
            if !(r.is_finite() && (0.0..=5.0).contains(&r)) {
                return Err(self.err("uavs", "body_radius_m", format!("must be in [0, 5] m (got {r})")));
            }
        }
        let n = s.cables.lengths_m.len();
        if n == 0 || n > SIM_MAX_UAVS {
            return Err(self.err("cables", "lengths_m", format!("needs 1..={SIM_MAX_UAVS} entries, one per UAV (got {n})")));
        }
        for &l in &s.cables.lengths_m {
            self.positive("cables", "lengths_m", l)?;
        }
        self.positive("cables", "stiffness_n_per_m", s.cables.stiffness_n_per_m)?;
        self.non_negative("cables", "damping_ns_per_m", s.cables.damping_ns_per_m)?;
        self.positive("cables", "rated_n", s.cables.rated_n)?;
        if let Some(b) = s.cables.breaking_n {
            if !(b.is_finite() && b > s.cables.rated_n) {
                return Err(self.err("cables", "breaking_n", format!("must be a finite number > rated_n = {} N (got {b})", s.cables.rated_n)));
            }
        }
        // Controller.
        let c = &s.controller;
        for (k, v) in [("k1", c.k1), ("k2", c.k2), ("k3", c.k3), ("v_max_mps", c.v_max_mps), ("r_safe_m", c.r_safe_m),
                       ("tray_height_m", c.tray_height_m), ("kz_per_s", c.kz_per_s), ("vz_max_mps", c.vz_max_mps)] {
            self.positive("controller", k, v)?;
        }
        for (k, v) in [("share_gain_mps_per_n", c.share_gain_mps_per_n), ("load_altitude_gain_per_s", c.load_altitude_gain_per_s),
                       ("share_offset_max_m", c.share_offset_max_m)] {
            self.non_negative("controller", k, v)?;
        }
        if !(c.r_active_m.is_finite() && c.r_active_m > c.r_safe_m) {
            return Err(self.err("controller", "r_active_m", format!("must be > r_safe_m = {} (got {})", c.r_safe_m, c.r_active_m)));
        }
        let cap = &c.capacity;
        self.non_negative("controller.capacity", "margin", cap.margin)?;
        if let Some(sep) = cap.separation_m {
            self.positive("controller.capacity", "separation_m", sep)?;
        }
        self.positive("controller.capacity", "rate_per_s", cap.rate_per_s)?;
        self.positive("controller.capacity", "sag_start_m", cap.sag_start_m)?;
        if !(cap.sag_full_m.is_finite() && cap.sag_full_m > cap.sag_start_m) {
            return Err(self.err("controller.capacity", "sag_full_m", format!("must be > sag_start_m = {} (got {})", cap.sag_start_m, cap.sag_full_m)));
        }
        self.non_negative("controller.shape", "margin_m", c.shape.margin_m)?;
        self.non_negative("controller.shape", "ahead_m", c.shape.ahead_m)?;
        let bl = &s.baseline;
        for (k, v) in [("k1", bl.k1), ("k2", bl.k2), ("k3", bl.k3), ("v_max_mps", bl.v_max_mps), ("r_safe_m", bl.r_safe_m)] {
            self.positive("baseline", k, v)?;
        }
        if !(bl.r_active_m.is_finite() && bl.r_active_m > bl.r_safe_m) {
            return Err(self.err("baseline", "r_active_m", "must be > r_safe_m".into()));
        }
        let vl = &s.velocity_loop;
        for (k, arr) in [("kp", vl.kp), ("ki", vl.ki), ("kd", vl.kd)] {
            if !arr.iter().all(|x| x.is_finite() && *x >= 0.0) {
                return Err(self.err("velocity_loop", k, "gains must be finite and >= 0".into()));
            }
        }
        // issue 17: the crate takes kd in [0, 1) (vt_cfo::VelocityLoopParams::new); said here
        // with a location instead of a bare SimError.
        if !vl.kd.iter().all(|&x| x < 1.0) {
            return Err(self.err("velocity_loop", "kd", format!("derivative gains must be < 1 (got {:?})", vl.kd)));
        }
        self.positive("velocity_loop", "cfo_bandwidth_rad_s", vl.cfo_bandwidth_rad_s)?;
        self.non_negative("velocity_loop", "actuator_lag_s", vl.actuator_lag_s)?;
        self.non_negative("velocity_loop", "command_filter_s", vl.command_filter_s)?;
        // issue 15: the vertical cap thrust_max sqrt(1 - r^2) must still lift the UAV (as
        // vt_cfo::ThrustLimits::with_horizontal_reserve and VelocityLoopParams::new check it).
        let explicit = [("velocity_loop", Some(vl.horizontal_reserve)), ("velocity_loop.rigid_body", vl.horizontal_reserve(UavModel::RigidBody))];
        for (table, r) in explicit.iter().filter_map(|(t, r)| r.map(|r| (*t, r))) {
            if !(r.is_finite() && (0.0..1.0).contains(&r)) {
                return Err(self.err(table, "horizontal_reserve", format!("must be in [0, 1) (got {r})")));
            }
            let vertical_max = s.uavs.thrust_max_n * (1.0 - r * r).sqrt();
            if s.uavs.mass_kg * f64::from(vt_cfo::GRAVITY_MPS2) > vertical_max {
                return Err(self.err(table, "horizontal_reserve", format!(
                    "leaves {vertical_max:.1} N of vertical thrust, less than the UAV's weight {:.1} N", s.uavs.mass_kg * f64::from(vt_cfo::GRAVITY_MPS2))));
            }
        }
        if let Some(t) = vl.rigid_body {
            if let Some(bw) = t.cfo_bandwidth_rad_s {
                self.positive("velocity_loop.rigid_body", "cfo_bandwidth_rad_s", bw)?;
            }
            if let Some(lag) = t.actuator_lag_s {
                self.non_negative("velocity_loop.rigid_body", "actuator_lag_s", lag)?;
            }
            if let Some(tau) = t.command_filter_s {
                self.non_negative("velocity_loop.rigid_body", "command_filter_s", tau)?;
            }
        }
        // Rates.
        let r = &s.rates;
        for (k, v) in [("plant_hz", r.plant_hz), ("plant_substeps", r.plant_substeps), ("low_level_hz", r.low_level_hz),
                       ("high_level_hz", r.high_level_hz), ("record_hz", r.record_hz)] {
            if v == 0 {
                return Err(self.err("rates", k, "must be > 0".into()));
            }
        }
        for (k, v) in [("low_level_hz", r.low_level_hz), ("high_level_hz", r.high_level_hz), ("record_hz", r.record_hz)] {
            if !r.plant_hz.is_multiple_of(v) {
                return Err(self.err("rates", k, format!("must divide plant_hz = {} evenly (got {v})", r.plant_hz)));
            }
        }
        if !r.low_level_hz.is_multiple_of(r.high_level_hz) {
            return Err(self.err("rates", "high_level_hz", "must divide low_level_hz evenly".into()));
        }
        let rigid_bw = vl.tuning(UavModel::RigidBody).0;
        for (table, bw) in [("velocity_loop", vl.cfo_bandwidth_rad_s), ("velocity_loop.rigid_body", rigid_bw)] {
            if bw / f64::from(r.low_level_hz) > 0.5 {
                return Err(self.err(table, "cfo_bandwidth_rad_s", format!(
                    "mu * h = {:.3} > 0.5: the discrete observer would be unstable at low_level_hz = {}",
                    bw / f64::from(r.low_level_hz), r.low_level_hz)));
            }
        }
        // Link and mission.
        self.non_negative("link", "delay_s", s.link.delay_s)?;
        if !(s.link.drop_probability.is_finite() && (0.0..1.0).contains(&s.link.drop_probability)) {
            return Err(self.err("link", "drop_probability", "must be in [0, 1)".into()));
        }
        self.positive("link", "stale_timeout_s", s.link.stale_timeout_s)?;
        // The firmware's FS_RESUME range.
        if !(s.failsafe.resume_s.is_finite() && (0.0..=10.0).contains(&s.failsafe.resume_s)) {
            return Err(self.err("failsafe", "resume_s", format!("must be in [0, 10] s (got {})", s.failsafe.resume_s)));
        }
        let m = &s.mission;
        for (k, v) in [("time_limit_s", m.time_limit_s), ("end_tolerance_m", m.end_tolerance_m),
                       ("safety_distance_m", m.safety_distance_m), ("altitude_tolerance_m", m.altitude_tolerance_m)] {
            self.positive("mission", k, v)?;
        }
        self.non_negative("mission", "post_arrival_s", m.post_arrival_s)?;
        // The companion's VT_CLR_MIN range.
        if let Some(c) = m.clearance_floor_m {
            if !(c.is_finite() && (0.0..=5.0).contains(&c)) {
                return Err(self.err("mission", "clearance_floor_m", format!("must be in [0, 5] m (got {c})")));
            }
        }
        let r_safe = s.uavs.flown_r_safe_m(s.controller.r_safe_m, m.clearance_floor());
        if r_safe >= s.controller.r_active_m {
            return Err(self.err("uavs", "body_radius_m", format!(
                "the tube safety radius this body needs, body_radius_m + clearance floor = {r_safe:.2} m, must stay below controller.r_active_m = {} m",
                s.controller.r_active_m)));
        }
        self.non_negative("mission", "settle_time_s", m.settle_time_s)?;
        if !(m.preflight_s.is_finite() && (0.0..=60.0).contains(&m.preflight_s)) {
            return Err(self.err("mission", "preflight_s", format!("must be in [0, 60] s (got {})", m.preflight_s)));
        }
        // The firmware's VT_CAL_N range.
        if !(1..=100_000).contains(&s.controller.survey_samples) {
            return Err(self.err("controller", "survey_samples", format!("must be in [1, 100000] (got {})", s.controller.survey_samples)));
        }
        let d = &s.disturbances;
        for (k, v) in [("position_noise_m", d.position_noise_m), ("velocity_noise_mps", d.velocity_noise_mps),
                       ("latency_s", d.latency_s), ("link_jitter_s", d.link_jitter_s), ("gust_std_mps", d.gust_std_mps),
                       ("uav_drag_area_m2", d.uav_drag_area_m2), ("load_drag_area_m2", d.load_drag_area_m2),
                       ("intensity", d.intensity)] {
            self.non_negative("disturbances", k, v)?;
        }
        if !(d.turbulence.is_finite() && (0.0..=3.0).contains(&(d.turbulence * d.intensity))) {
            return Err(self.err("disturbances", "turbulence", format!("turbulence x intensity must be in [0, 3] (got {})", d.turbulence * d.intensity)));
        }
        self.positive("disturbances", "gust_tau_s", d.gust_tau_s)?;
        let z0_max = crate::disturbance::WIND_REFERENCE_HEIGHT_M / 10.0;
        if !(d.surface_roughness_m.is_finite() && (0.0..=z0_max).contains(&d.surface_roughness_m)) {
            return Err(self.err("disturbances", "surface_roughness_m", format!("must be in [0, {z0_max:.2}] m (got {}): 0 for a uniform wind, 0.03 open grass, 0.5 scattered buildings", d.surface_roughness_m)));
        }
        if let Some(t) = d.wind_onset_s {
            self.non_negative("disturbances", "wind_onset_s", t)?;
        }
        for (field, scale) in [("error_scale", s.sensing.error_scale), ("attitude_error_scale", s.sensing.attitude_error_scale)] {
            if let Some(k) = scale {
                if !(k.is_finite() && (0.0..=100.0).contains(&k)) {
                    return Err(self.err("sensing", field, format!("must be in [0, 100] (got {k})")));
                }
            }
        }
        if s.sensing.attitude != crate::sensing::AttitudeModel::True && s.uavs.model != crate::models::UavModel::RigidBody {
            return Err(self.err("sensing", "attitude", "the attitude estimate needs the rigid-body plant (`[uavs] model = \"rigid_body\"`): a point mass has no attitude".into()));
        }
        if !d.wind_mean_mps.iter().all(|x| x.is_finite()) {
            return Err(self.err("disturbances", "wind_mean_mps", "must be finite".into()));
        }
        for (k, v) in [("cable_length_error", d.cable_length_error), ("cable_stiffness_error", d.cable_stiffness_error),
                       ("uav_mass_error", d.uav_mass_error), ("load_mass_error", d.load_mass_error),
                       ("thrust_scale_error", d.thrust_scale_error)] {
            if !(v.is_finite() && (0.0..0.9).contains(&(v * d.intensity))) {
                return Err(self.err("disturbances", k, format!("relative error x intensity must be in [0, 0.9) (got {})", v * d.intensity)));
            }
        }
        for (i, f) in s.faults.iter().enumerate() {
            if f.uav >= s.cables.lengths_m.len() {
                return Err(ScenarioError {
                    source_name: self.source_name.into(),
                    line: nth_table_line(self.text, "faults", i),
                    field: Some(format!("faults[{i}].uav")),
                    message: format!("no UAV {} in a team of {}", f.uav, s.cables.lengths_m.len()),
                });
            }
            if !(f.time_s.is_finite() && f.time_s >= 0.0) {
                return Err(ScenarioError {
                    source_name: self.source_name.into(),
                    line: nth_table_line(self.text, "faults", i),
                    field: Some(format!("faults[{i}].time_s")),
                    message: "must be a finite time >= 0".into(),
                });
            }
            let duration_err = |message: String| ScenarioError {
                source_name: self.source_name.into(),
                line: nth_table_key_line(self.text, "faults", i, "duration_s"),
                field: Some(format!("faults[{i}].duration_s")),
                message,
            };
            match (f.kind, f.duration_s) {
                (FaultKind::OwnFeedStall, None) => {
                    return Err(duration_err("`own_feed_stall` needs its duration: a finite time > 0, s".into()))
                }
                (FaultKind::OwnFeedStall, Some(d)) if !(d.is_finite() && d > 0.0) => {
                    return Err(duration_err(format!("must be a finite time > 0 (got {d})")))
                }
                (FaultKind::OwnFeedStall, _) | (_, None) => {}
                (_, Some(_)) => return Err(duration_err("only `own_feed_stall` lasts a duration; the other faults are for good".into())),
            }
        }
        // Cable stiffness against the integrator's sub-step (docs/plant.md).
        let h = 1.0 / (f64::from(s.rates.plant_hz) * f64::from(s.rates.plant_substeps.max(1)));
        match check_cable_integration(s.cables.stiffness_n_per_m, s.cables.damping_ns_per_m, s.uavs.mass_kg, s.load.mass_kg.min(s.load.plant_mass_kg()), h) {
            Ok(()) => {}
            Err(StiffnessError::Stiffness { omega_h }) => {
                return Err(self.err("cables", "stiffness_n_per_m", format!(
                    "too stiff for the plant step: sqrt(k/mu) h = {omega_h:.3} > {MAX_OMEGA_H} (mu: reduced UAV-load mass, h = 1/(plant_hz plant_substeps) = {h:.2e} s); raise rates.plant_substeps or lower the stiffness")));
            }
            Err(StiffnessError::Damping { damping_h }) => {
                return Err(self.err("cables", "damping_ns_per_m", format!(
                    "too much damping for the plant step: (b/mu) h = {damping_h:.3} > {MAX_DAMPING_H}; raise rates.plant_substeps or lower the damping")));
            }
        }
        // Geometry: tube, obstacles, formation, cables.
        let tube = self.check_tube(s)?;
        self.check_perception(s)?;
        // An unknown map's tube is planned on the bounds alone: the real obstacles may cross it
        // (the team finds them in flight).
        if s.perception.map == MapKnowledge::Known {
            self.check_obstacles(s, &tube)?;
        }
        self.check_formation(s, &tube)?;
        self.check_preflight(s)?;
        Ok(tube)
    }

    /// The pre-flight feasibility check (docs/design.md, "Pre-flight feasibility check"): the
    /// team carries the declared load with `preflight.min_margin` at the take-off lean, or the
    /// scenario is refused before anything flies.
    fn check_preflight(&self, s: &Scenario) -> Result<(), ScenarioError> {
        self.check_wind(s)?;
        let m = s.preflight.min_margin;
        if !(m.is_finite() && m > -1.0 && m <= 10.0) {
            return Err(self.err("preflight", "min_margin", format!("must be a fraction in (-1, 10] (got {m})")));
        }
        let r = s.preflight.thrust_reserve;
        if !(r.is_finite() && (0.0..=0.5).contains(&r)) {
            return Err(self.err("preflight", "thrust_reserve", format!("must be a fraction in [0, 0.5] (got {r})")));
        }
        match crate::sim::preflight(s, s.cables.rated_n) {
            Ok(_) => Ok(()),
            Err(e @ vt_dissipative::FeasibilityError::Infeasible { .. }) => {
                let Some(p) = crate::sim::feasibility_at_takeoff(s, s.cables.rated_n) else {
                    return Err(self.err("load", "mass_kg", e.to_string()));
                };
                let rotor = vt_dissipative::feasibility::rotor_capacity_n(p.uav_mass_kg * vt_dissipative::calibration::GRAVITY_MPS2, p.sustained_thrust_n(), p.tilt_max_rad, p.cos_lean);
                Err(self.err("load", "mass_kg", format!(
                    "{e}; {} UAVs x min(cable rated {:.1} N, rotors {rotor:.1} N at {:.0} % of their thrust) at the take-off lean cos {:.4}: lower the load, add UAVs, \
                     stand the cables more vertical, or set [preflight] min_margin or thrust_reserve",
                    p.n_uavs, p.cable_rated_n, 100.0 * (1.0 - p.thrust_reserve), p.cos_lean)))
            }
            Err(e) => Err(self.err("preflight", "min_margin", e.to_string())),
        }
    }

    /// The pre-flight wind check (docs/design.md, "Wind capacity"): with a declared wind, the
    /// team must hold it plus the gust margin in the tube, as every companion checks at
    /// `MISSION_START` (`VT_WIND_DECL`), or the scenario is refused before anything flies.
    fn check_wind(&self, s: &Scenario) -> Result<(), ScenarioError> {
        let g = s.mission.gust_margin_mps;
        if !(g.is_finite() && (0.0..=100.0).contains(&g)) {
            return Err(self.err("mission", "gust_margin_mps", format!("must be in [0, 100] m/s (got {g})")));
        }
        let Some(w) = s.mission.max_wind_mps else { return Ok(()) };
        if !(w.is_finite() && (0.0..=100.0).contains(&w)) {
            return Err(self.err("mission", "max_wind_mps", format!("must be in [0, 100] m/s (got {w})")));
        }
        match crate::sim::wind_preflight(s, s.cables.rated_n) {
            Ok(_) => Ok(()),
            Err(e @ vt_dissipative::wind::WindError::TooStrong { .. }) => Err(self.err("mission", "max_wind_mps", format!(
                "{e}: the team would be blown out of the tube; fly in less wind, with stronger or more UAVs, or a lighter or smaller load"))),
            Err(e) => Err(self.err("mission", "max_wind_mps", e.to_string())),
        }
    }

    fn check_tube(&self, s: &Scenario) -> Result<SimTube, ScenarioError> {
        let tube = SimTube::from_waypoints(&s.tube.waypoints_f32()).map_err(|e| self.err("tube", "waypoints", e.to_string()))?;
        // The narrowest section must hold a UAV with its safety margin on both sides.
        let need = s.mission.safety_distance_m + s.uavs.flown_r_safe_m(s.controller.r_safe_m, s.mission.clearance_floor());
        if f64::from(tube.min_half_width_m()) <= need {
            return Err(self.err("tube", "waypoints", format!(
                "narrowest half-width {:.2} m cannot hold a UAV: needs > r_safe_m + safety_distance_m = {need:.2} m",
                tube.min_half_width_m())));
        }
        Ok(tube)
    }

    /// Issue 28: `[perception]`, `[sensors.lidar]`, `[[world.appear]]`.
    fn check_perception(&self, s: &Scenario) -> Result<(), ScenarioError> {
        let p = &s.perception;
        if let Some(l) = &s.sensors.lidar {
            if let Some((key, message)) = l.invalid(f64::from(s.rates.high_level_hz)) {
                return Err(self.err("sensors.lidar", key, message));
            }
        }
        if !(p.replan_hz > 0.0 && p.replan_hz <= 10.0) {
            return Err(self.err("perception", "replan_hz", format!("must be in (0, 10] Hz (got {})", p.replan_hz)));
        }
        if !(p.cell_m >= 0.05 && p.cell_m <= 2.0) {
            return Err(self.err("perception", "cell_m", format!("must be in [0.05, 2] m (got {})", p.cell_m)));
        }
        if p.map == MapKnowledge::Unknown {
            if s.sensors.lidar.is_none() {
                return Err(self.err("perception", "map", "`unknown` needs a sensor to map with: add `[sensors.lidar]`".into()));
            }
            if s.tube.plan.is_none() {
                return Err(self.err("perception", "map", "`unknown` needs `[tube] plan = { start, goal }`: the team plans its own tube".into()));
            }
            let b = s.world.bounds_m;
            let cells = ((b[1] - b[0]) / p.cell_m).ceil() * ((b[3] - b[2]) / p.cell_m).ceil();
            if cells > vt_companion::perception::MAP_CELLS as f64 {
                return Err(self.err("perception", "cell_m", format!(
                    "the onboard map of the {:.0} x {:.0} m world at {} m needs {cells:.0} cells, more than its {} (use coarser cells)",
                    b[1] - b[0], b[3] - b[2], p.cell_m, vt_companion::perception::MAP_CELLS)));
            }
        }
        for (i, a) in s.world.appear.iter().enumerate() {
            if let Err((key, message)) = a.shape() {
                return Err(ScenarioError {
                    source_name: self.source_name.into(),
                    line: nth_table_key_line(self.text, "world.appear", i, key),
                    field: Some(format!("world.appear[{i}].{key}")),
                    message,
                });
            }
        }
        Ok(())
    }

    fn check_obstacles(&self, s: &Scenario, tube: &SimTube) -> Result<(), ScenarioError> {
        const RIM_POINTS: usize = 72;
        for (i, o) in s.world.obstacles.iter().enumerate() {
            let c = vt_tube::Vec2::new(o.center_m[0] as f32, o.center_m[1] as f32);
            let r = o.radius_m as f32;
            let inside = |p: vt_tube::Vec2| tube.locate(p, 0).is_some_and(|sec| sec.boundary_distance_m(p) > 0.0);
            let rim_hit = (0..RIM_POINTS).any(|k| {
                let a = k as f32 / RIM_POINTS as f32 * core::f32::consts::TAU;
                inside(c + vt_tube::Vec2::new(a.cos(), a.sin()) * r)
            });
            let boundary_hit = tube.samples().iter().any(|smp| {
                (smp.left_boundary_m() - c).norm() < r || (smp.right_boundary_m() - c).norm() < r
            });
            if inside(c) || rim_hit || boundary_hit {
                return Err(ScenarioError {
                    source_name: self.source_name.into(),
                    line: nth_table_line(self.text, "world.obstacles", i),
                    field: Some(format!("world.obstacles[{i}]")),
                    message: format!("obstacle at ({:.2}, {:.2}) r = {:.2} m intrudes into the tube", o.center_m[0], o.center_m[1], o.radius_m),
                });
            }
        }
        Ok(())
    }

    fn check_formation(&self, s: &Scenario, tube: &SimTube) -> Result<(), ScenarioError> {
        let h = s.controller.tray_height_m;
        let r = s.uavs.formation_reach_m();
        let layout = layout_field(s);
        let offsets = s.uavs.formation_offsets(s.cables.lengths_m.len());
        let node_m = |i: usize| offsets.get(i).map_or(r, |d| d[0].hypot(d[1]));
        for (i, &len) in s.cables.lengths_m.iter().enumerate() {
            // Taut cable with its node on the take-off layout: height above the load.
            let height = len / (1.0 + (node_m(i) / h).powi(2)).sqrt();
            if height < 1.0 {
                return Err(self.err("cables", "lengths_m", format!(
                    "cable {i} ({len} m) is too short for the formation: the UAV would be {height:.2} m above the load")));
            }
            if s.load.altitude_m + height + 0.5 > s.world.ceiling_m {
                return Err(self.err("load", "altitude_m", format!(
                    "UAV {i} would fly at {:.1} m, above the ceiling {} m", s.load.altitude_m + height, s.world.ceiling_m)));
            }
        }
        let s0 = s.load.start_s_m as f32;
        if s0 >= tube.length_m() {
            return Err(self.err("load", "start_s_m", format!("beyond the tube end ({:.1} m)", tube.length_m())));
        }
        let k = ((s0 / tube.ds_m()) as usize).min(TUBE_SAMPLES - 1);
        let smp = tube.samples().get(k).copied().ok_or_else(|| self.err("load", "start_s_m", "out of range".into()))?;
        let half = 0.5 * (smp.w_left_m + smp.w_right_m);
        if f64::from(half) <= r + s.controller.r_safe_m {
            return Err(self.err("uavs", layout, format!(
                "take-off formation (reach {r} m + r_safe {} m) does not fit the tube at the start (half-width {half:.2} m)",
                s.controller.r_safe_m)));
        }
        // A UAV on a cable longer than the tray's slant `sqrt(r^2 + h^2)` sits beyond its node,
        // at `L r / sqrt(r^2 + h^2)` from the load (capacity.rs, `uav_rel`): it must fit too.
        for (i, &len) in s.cables.lengths_m.iter().enumerate() {
            let d = node_m(i);
            let out = len * d / (d * d + h * h).sqrt();
            if f64::from(half) <= out + s.controller.r_safe_m {
                return Err(self.err("cables", "lengths_m", format!(
                    "UAV {i} on its {len} m cable takes off {out:.2} m from the load, beyond the tube at the start with r_safe {} m (half-width {half:.2} m)",
                    s.controller.r_safe_m)));
            }
        }
        self.check_takeoff_places(s, tube)?;
        self.check_takeoff_bodies(s, tube)
    }

    /// Every UAV of the take-off formation, and its node, at its *own* section of the tube keeps
    /// the flown `r_safe` to the boundary: the tube barrier (eq:2-15) then starts finite for
    /// every node, the initial condition of the paper's Theorem 1. The checks above measure the
    /// half-width at the load's section only; a tube that narrows within the formation's reach of
    /// the start passed them with a UAV inside the barrier's safety radius from the first step
    /// (generated narrowings: 0.17-0.40 m from the wall at t = 0; docs/design.md, "Take-off
    /// places inside the tube").
    fn check_takeoff_places(&self, s: &Scenario, tube: &SimTube) -> Result<(), ScenarioError> {
        let r_safe = s.uavs.flown_r_safe_m(s.controller.r_safe_m, s.mission.clearance_floor());
        let t = crate::sim::takeoff(s, tube, s.cables.rated_n);
        for (i, (p, q)) in t.uav_pos_m.iter().zip(&t.nodes_m).enumerate() {
            let uav = vt_tube::Vec2::new(p.x as f32, p.y as f32);
            let node = vt_tube::Vec2::new(q[0] as f32, q[1] as f32);
            let clear = |q: vt_tube::Vec2| tube.locate(q, 0).map_or(f32::NEG_INFINITY, |sec| sec.boundary_distance_m(q));
            let (d_uav, d_node) = (clear(uav), clear(node));
            let d = f64::from(d_uav.min(d_node));
            // A NaN distance is refused too.
            if d.is_nan() || d < r_safe {
                return Err(self.err("uavs", layout_field(s), format!(
                    "UAV {i} takes off {d_uav:.2} m from the tube's boundary (its node {d_node:.2} m), within r_safe {r_safe:.2} m: the tube narrows within the take-off formation's reach of the start")));
            }
        }
        Ok(())
    }
}

/// Line of the `index`-th `[[table]]` header.
fn nth_table_line(text: &str, table: &str, index: usize) -> Option<usize> {
    let header = format!("[[{table}]]");
    text.lines().enumerate().filter(|(_, l)| l.split('#').next().unwrap_or_default().trim() == header).nth(index).map(|(i, _)| i + 1)
}

/// Line of `key` in the `index`-th `[[table]]` (1-based), else that table's header line.
fn nth_table_key_line(text: &str, table: &str, index: usize, key: &str) -> Option<usize> {
    let start = nth_table_line(text, table, index)?;
    text.lines()
        .enumerate()
        .skip(start)
        .take_while(|(_, l)| !l.trim_start().starts_with('['))
        .find(|(_, l)| l.split('#').next().unwrap_or_default().split_once('=').is_some_and(|(k, _)| k.trim() == key))
        .map_or(Some(start), |(i, _)| Some(i + 1))
}
