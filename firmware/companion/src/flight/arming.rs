//! The arming and the high-level law it arms (`VT_CTRL`): the calibration, the pre-flight and
//! wind checks, the take-off formation (eq:2-7) and the controller, dissipative or baseline.

use vt_dissipative::{capacity, BaselineController, BaselineParams, Command, DissipativeController, Formation, FormationScale, Measurements, ShapeSeparation};

use super::StartError;
use crate::params::{Param, Params};
use crate::{CompanionTube, Vec3, MAX_UAVS};

/// The high-level law flown (`VT_CTRL`).
#[derive(Debug, Clone)]
#[allow(clippy::large_enum_variant)] // no heap on the MCU, and one flight exists per board
pub(super) enum HighLevel {
    /// The paper's dissipative controller (tube passing, virtual springs, capacity-aware
    /// formation).
    Dissipative(DissipativeController<MAX_UAVS>),
    /// Traditional virtual-tube control (REFERENCE §2), the paper's comparison.
    Baseline(BaselineController),
}

impl HighLevel {
    pub(super) fn set_team_hold(&mut self, hold: bool) {
        match self {
            Self::Dissipative(c) => c.set_team_hold(hold),
            Self::Baseline(c) => c.set_team_hold(hold),
        }
    }

    /// The dissipative controller's anchored team hold; the baseline's hold is its own (it
    /// holds no formation a spring could restore).
    pub(super) fn anchor_team_hold(&mut self) {
        if let Self::Dissipative(c) = self {
            c.anchor_team_hold();
        }
    }

    pub(super) fn set_heaving(&mut self, heaving: bool) {
        if let Self::Dissipative(c) = self {
            c.set_heaving(heaving);
        }
    }

    pub(super) fn set_load_altitude_ref(&mut self, z_m: f32, sharing: vt_dissipative::vertical::Sharing) {
        match self {
            Self::Dissipative(c) => c.set_load_altitude_ref(z_m, sharing),
            Self::Baseline(c) => c.set_load_altitude_ref(z_m, sharing),
        }
    }

    pub(super) fn update(&mut self, tube: &CompanionTube, m: &Measurements<'_>, dt_s: f32) -> Command {
        match self {
            Self::Dissipative(c) => c.update(tube, m, dt_s),
            Self::Baseline(c) => c.update(tube, m, dt_s),
        }
    }
}

/// The arming: the cable calibration from the positions of every UAV and the load
/// (`vt_dissipative::calibrate`), the pre-flight check at the measured lean
/// (`vt_dissipative::feasibility::check`), the declared wind's check, the take-off formation
/// (eq:2-7), then the high-level law (`VT_CTRL`). `seen_wind_mps`: a ground start's hover's
/// mean wind and gust margin (m/s, `vt_dissipative::wind::GustSurvey`).
#[inline(never)] // its frame is large: it must not merge into the high-level step's
pub(super) fn arm(params: &Params, id: usize, n: usize, takeoff: &[Vec3], load_pos_m: &Vec3, seen_wind_mps: Option<(f32, f32)>) -> Result<(HighLevel, f32), StartError> {
    let cal = vt_dissipative::calibrate(id, takeoff, load_pos_m, &params.calibration()).map_err(StartError::Calibration)?;
    vt_dissipative::feasibility::check(&params.feasibility(cal.cos_lean)).map_err(StartError::Infeasible)?;
    // The declared wind and gust margin, and those a ground start's hover saw: the larger of
    // each is checked.
    let declared = params.declared_wind_mps();
    let wind = match (declared, seen_wind_mps) {
        (Some((w, g)), seen) => Some(seen.map_or((w, g), |(s, sg)| (s.max(w), sg.max(g)))),
        (None, Some((seen, gust))) => Some((seen, gust.max(params.get(Param::WindGust)))),
        (None, None) => None,
    };
    if let Some((wind_mps, gust_mps)) = wind {
        vt_dissipative::wind::check(&params.wind(cal.cos_lean), wind_mps, gust_mps).map_err(StartError::Wind)?;
    }
    let dissipative = params.dissipative(&cal).map_err(StartError::Controller)?;
    let tray = params.tray();
    let formation = Formation::<MAX_UAVS>::from_takeoff(takeoff, load_pos_m, &tray).map_err(StartError::Controller)?;
    // Capacity-aware formation (issue 15): every UAV plans from the same take-off measurement.
    let cap = params.capacity().map_err(StartError::Controller)?;
    let plan = capacity::plan_from_takeoff(takeoff, load_pos_m, &tray, &cap).map_err(StartError::Controller)?;
    let high = if params.get_u32(Param::Ctrl) == 1 {
        let baseline = BaselineParams {
            k1: dissipative.k1,
            k2: dissipative.k2,
            k3: dissipative.k3,
            v_max_mps: dissipative.v_max_mps,
            // The published radii as given: `VT_BODY_R` shapes the dissipative controller only.
            r_safe_m: params.get(Param::RSafe),
            r_active_m: dissipative.r_active_m,
            vertical: dissipative.vertical,
        };
        HighLevel::Baseline(BaselineController::new(id, n, baseline).map_err(StartError::Controller)?)
    } else {
        // A team near its capacity flies slower (docs/design.md, "A team near its capacity flies
        // slower"): every UAV from the same plan ...
        let mut dissipative = dissipative;
        dissipative.v_max_mps *= capacity::speed_fraction(plan.margin());
        // ... with a dashpot beside each spring (docs/design.md, "A dashpot beside the springs
        // of a team near its capacity").
        dissipative.dashpot = capacity::dashpot_gain(plan.margin());
        let mut high = DissipativeController::new(id, dissipative, &formation).map_err(StartError::Controller)?;
        high.set_capacity(FormationScale::new(&plan, &cap));
        if let Some(shape) = params.shape() {
            // With bodies declared (`VT_BODY_R`), the stadium keeps `formation_separation_m`
            // where the UAVs fly (from their taut cables at take-off, vt_dissipative::shape),
            // lengthening down to the load's own weight (`weight_cos_sum`: a passage spends the
            // margin, never the load). Without, it is as long as the ring (docs/design.md).
            let sep = (params.separation_m() > 0.0).then_some(ShapeSeparation { takeoff_m: takeoff, load_m: *load_pos_m, separation_m: cap.separation_m, min_cos_sum: cap.weight_cos_sum() });
            high.set_shape(shape, &formation, sep).map_err(StartError::Controller)?;
            high.set_team_keeping(params.team_keeping());
        }
        HighLevel::Dissipative(high)
    };
    Ok((high, plan.margin()))
}

/// Issue 28 and 27 §1: the narrowest tube half-width the formation UAV `PR`/`VT_ID` of `params`
/// would arm with from `takeoff` and `load_pos_m` keeps its separation floor in, m
/// (`DissipativeController::shaped_need_half_width_m`, framed by the tube's direction
/// `tangent_xy` at the load, as the first look frames an air start's). A planner on a known map
/// asks for it before the flight; aboard, a re-plan asks the armed formation
/// ([`crate::flight::Flight::shaped_need_half_width_m`]). `None` without a shape with a floor, for the
/// baseline, or when the arming would refuse (its own error says why at the start).
#[cfg(feature = "std")]
pub fn shaped_need_at_arming_m(params: &Params, takeoff: &[Vec3], load_pos_m: &Vec3, tangent_xy: vt_tube::Vec2) -> Option<f32> {
    let n = params.get_u32(Param::NUavs) as usize;
    let id = params.get_u32(Param::Id) as usize;
    match arm(params, id, n, takeoff.get(..n)?, load_pos_m, None).ok()?.0 {
        HighLevel::Dissipative(c) => c.shaped_need_half_width_m(&tangent_xy),
        HighLevel::Baseline(_) => None,
    }
}
