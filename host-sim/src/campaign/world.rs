//! The world a campaign flies in (issue 27 §5): the base scenario's own, or the world a real
//! aircraft flies in, with every model of issue 27 on (docs/robustness.md, "Every campaign in
//! the real-aircraft world").
//!
//! The real-aircraft world is a table merged over the base scenario and under the campaign's
//! own tables, so a campaign can still set any of its keys. On a rigid-body base it sets:
//! - `[mission] start = "ground"` (lift-off, transport, set-down) and
//!   `clearance_floor_m = 0.2` (success needs every surface-to-surface clearance);
//! - `[uavs] autopilot = "px4_default"` (PX4's stock rate gains), with the observer's lag
//!   matched to it and to the airframe (`[velocity_loop.rigid_body] actuator_lag_s`: 0.08 s on
//!   the paper's 2 kg airframe, `vt_sim::observer_lag`);
//! - `[uavs] body_radius_m`: the sized airframe's envelope, declared to the companions, and
//!   `[controller.shape] enabled = true` (the formation shaped to the tube); a generated
//!   campaign draws its airframe per run, and its generator declares the drawn airframe's body
//!   (`vt_sim::scenario::generate`, since session 52);
//! - `[controller]` load sharing on (`share_gain_mps_per_n`, `load_altitude_gain_per_s`,
//!   `share_offset_max_m`: [`SHARE_GAIN_MPS_PER_N`] and the two below it), which evens out the
//!   tensions that the take-off's RTK-measured cable lengths leave uneven (docs/design.md,
//!   "Load sharing in the real-aircraft world");
//! - `[sensing] position = "rtk"`, `attitude = "px4"`;
//! - `[disturbances] turbulence = 1` (light Dryden) and `thrust_scale_error = 0.05`, both
//!   scaled by the campaign's intensity like the other disturbances.
//!
//! A `point_mass` base keeps its own world: the paper comparison is judged on the paper's
//! centre floors (issue 27 §1).

use crate::scenario::{ScenarioError, UavSpec};
use toml::{Table, Value};

/// Observer lag matched to PX4's stock rate gains on the paper's airframe, s (docs/design.md,
/// "Velocity loop behind an attitude autopilot"); other airframes get theirs by
/// `vt_sim::observer_lag::stock_observer_lag_s`.
pub const STOCK_AUTOPILOT_LAG_S: f64 = vt_sim::observer_lag::STOCK_AUTOPILOT_LAG_S;

/// The success floor between surfaces in the real-aircraft world, m (issue 27 §1).
pub const CLEARANCE_FLOOR_M: f64 = 0.2;

/// Light Dryden turbulence (`[disturbances] turbulence`, issue 27 §4).
pub const TURBULENCE: f64 = 1.0;

/// Spread of each UAV's true maximum thrust about what its firmware believes (issue 27 §4).
pub const THRUST_SCALE_ERROR: f64 = 0.05;

/// Load-sharing gain `k_T` of the real-aircraft world's teams, (m/s)/N (docs/design.md, "Load
/// sharing in the real-aircraft world"; `vt_dissipative::vertical`).
pub const SHARE_GAIN_MPS_PER_N: f64 = 0.001;

/// Load-altitude gain `k_L` of the sharing integrator in the real-aircraft world, 1/s.
pub const LOAD_ALTITUDE_GAIN_PER_S: f64 = 0.1;

/// Bound on each UAV's sharing altitude offset in the real-aircraft world, m.
pub const SHARE_OFFSET_MAX_M: f64 = 0.3;

/// Which world a campaign flies in (campaign key `world`, `host-sim sweep --world`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum World {
    /// The base scenario as written, with the campaign's tables over it.
    Scenario,
    /// The real-aircraft world over the base (module doc); the campaigns' default.
    #[default]
    RealAircraft,
}

impl World {
    /// The world named `s` (`real-aircraft` is accepted for `real_aircraft`).
    ///
    /// # Errors
    /// Any other name: the message lists the two.
    pub fn parse(s: &str) -> Result<Self, String> {
        match s {
            "scenario" => Ok(Self::Scenario),
            "real_aircraft" | "real-aircraft" => Ok(Self::RealAircraft),
            other => Err(format!("unknown world `{other}` (expected \"scenario\" or \"real_aircraft\")")),
        }
    }

    /// The table this world merges over the base scenario, for `base`: the base with the
    /// campaign's own tables merged over it. Empty for [`World::Scenario`] and for a
    /// `point_mass` team. `generated` leaves the bodies to the generator,
    /// which declares the drawn airframe's (module doc).
    ///
    /// # Errors
    /// A `[uavs]` table that does not parse (the scenario's own validation names it).
    pub fn overlay(self, base: &Table, generated: bool, source: &str) -> Result<Table, ScenarioError> {
        let mut over = Table::new();
        if self == Self::Scenario {
            return Ok(over);
        }
        let uavs = base.get("uavs").cloned().unwrap_or_else(|| Value::Table(Table::new()));
        let spec: UavSpec = uavs.try_into().map_err(|e: toml::de::Error| ScenarioError {
            source_name: source.into(),
            line: None,
            field: Some("uavs".into()),
            message: e.message().trim().to_string(),
        })?;
        if spec.model != vt_sim::models::UavModel::RigidBody {
            return Ok(over);
        }
        let table = |pairs: &[(&str, Value)]| Value::Table(pairs.iter().map(|(k, v)| ((*k).to_string(), v.clone())).collect());
        over.insert("mission".into(), table(&[("start", "ground".into()), ("clearance_floor_m", CLEARANCE_FLOOR_M.into())]));
        let mut uav_keys = vec![("autopilot", Value::from("px4_default"))];
        if !generated && spec.body_radius_m.is_none() {
            uav_keys.push(("body_radius_m", spec.envelope_radius_m(spec.model).into()));
        }
        over.insert("uavs".into(), table(&uav_keys));
        let mut controller = vec![
            ("share_gain_mps_per_n", Value::from(SHARE_GAIN_MPS_PER_N)),
            ("load_altitude_gain_per_s", Value::from(LOAD_ALTITUDE_GAIN_PER_S)),
            ("share_offset_max_m", Value::from(SHARE_OFFSET_MAX_M)),
        ];
        if !generated {
            controller.push(("shape", table(&[("enabled", true.into())])));
        }
        over.insert("controller".into(), table(&controller));
        if base.contains_key("velocity_loop") {
            // The observer's lag matched to the airframe behind the stock gains (docs/design.md,
            // "The observer's lag matched to each airframe"); a generated team's, drawn per
            // run, is matched by the generator.
            let lag = vt_sim::observer_lag::stock_observer_lag_s(spec.mass_kg, spec.thrust_max_n);
            over.insert("velocity_loop".into(), table(&[("rigid_body", table(&[("actuator_lag_s", lag.into())]))]));
        }
        over.insert("sensing".into(), table(&[("position", "rtk".into()), ("attitude", "px4".into())]));
        over.insert(
            "disturbances".into(),
            table(&[("turbulence", TURBULENCE.into()), ("thrust_scale_error", THRUST_SCALE_ERROR.into())]),
        );
        Ok(over)
    }
}
