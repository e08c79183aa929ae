//! Builds the plant a scenario describes, at rest at take-off.

use super::{LoadParams, Plant, PlantError, UavParams};
use crate::cable::CableParams;
use crate::disturbance::ParameterDraw;
use crate::models::{CableModel, UavModel, DEFAULT_BREAKING_FACTOR};
use crate::scenario::Scenario;
use crate::quadrotor::Quadrotor;
use crate::sim::Takeoff;
use nalgebra::Vector3;

/// The plant of scenario `s` with its true parameters (`draw`: the disturbance draw of UAV and
/// load masses; `true_len_m`, `true_k_n_per_m`: each cable's true rest length and stiffness),
/// every UAV at its take-off position with the cables taut and each UAV trimmed in hover (thrust
/// balancing gravity and its cable), for `uav_model` and `cable_model` with rated capacity
/// `rated_n`. The `paper_clamp` cable caps the tension at `rated_n` and never breaks; the
/// `elastic` one has no cap and breaks above `breaking_n` (the scenario's, else
/// [`DEFAULT_BREAKING_FACTOR`]` x rated_n`).
///
/// # Errors
/// [`PlantError`] for parameters the plant rejects.
#[allow(clippy::too_many_arguments)]
pub fn build(
    s: &Scenario,
    draw: &ParameterDraw,
    true_len_m: &[f64],
    true_k_n_per_m: &[f64],
    to: &Takeoff,
    uav_model: UavModel,
    cable_model: CableModel,
    rated_n: f64,
) -> Result<Plant, PlantError> {
    let uav_params: Vec<UavParams> = draw
        .uav_mass
        .iter()
        .zip(&draw.thrust_scale)
        .map(|(k, t)| UavParams { mass_kg: s.uavs.mass_kg * k, thrust_max_n: s.uavs.thrust_max_n * t, thrust_lag_s: s.uavs.thrust_lag_s })
        .collect();
    let cap = match cable_model {
        CableModel::PaperClamp => rated_n,
        CableModel::Elastic => f64::INFINITY,
    };
    let cables: Vec<CableParams> = true_len_m
        .iter()
        .zip(true_k_n_per_m)
        .map(|(&l, &k)| CableParams { rest_length_m: l, stiffness_n_per_m: k, damping_ns_per_m: s.cables.damping_ns_per_m, f_max_n: cap })
        .collect();
    let load = LoadParams { mass_kg: s.load.plant_mass_kg() * draw.load_mass };
    let mut plant = Plant::new(uav_params, cables, load, &to.uav_pos_m, to.load_pos_m, s.rates.plant_substeps as usize)?;
    let breaking = match cable_model {
        CableModel::PaperClamp => f64::INFINITY,
        CableModel::Elastic => s.cables.breaking_n.unwrap_or(DEFAULT_BREAKING_FACTOR * rated_n),
    };
    plant.set_breaking_strengths(vec![breaking; true_len_m.len()]);
    match uav_model {
        UavModel::PointMass => {
            let hover = plant.hover_thrust();
            for (u, t) in plant.uavs.iter_mut().zip(hover.iter()) {
                u.thrust_n = *t;
            }
        }
        UavModel::RigidBody => {
            // Each UAV's airframe sized from its (drawn) mass and the scenario's thrust limit,
            // so that normalised thrust 1 is `thrust_max_n` for the plant as for the firmware;
            // then its rotors given the drawn thrust error (the same normalised command gives
            // that much more or less thrust than the firmware believes).
            let quads = draw
                .uav_mass
                .iter()
                .zip(&draw.thrust_scale)
                .zip(&to.uav_pos_m)
                .enumerate()
                .map(|(index, ((k, t), p))| {
                    let mut q = Quadrotor::new(s.uavs.airframe(s.uavs.mass_kg * k), *p, Vector3::zeros())
                        .map_err(|error| PlantError::Quadrotor { index, error })?;
                    q.set_thrust_scale(*t);
                    Ok(q)
                })
                .collect::<Result<Vec<_>, _>>()?;
            plant.fit_quadrotors(quads).map_err(|error| PlantError::Quadrotor { index: 0, error })?;
        }
    }
    Ok(plant)
}
