//! Virtual springs between nodes (eq:2-5 .. eq:2-7) and their energy (Prop. 1, eq:2-8).
//!
//! Nodes: the n UAV nodes, the load node `l` (the load's horizontal position) and the tray
//! centre `u`. Connection matrix `W` (eq:2-5, REFERENCE §3): every pair of UAV nodes, and
//! each UAV node with `l` and with `u`; not `l`-`u`. Rest lengths are the take-off distances
//! (eq:2-7). The tray centre's take-off position is the centroid of the UAV nodes.
//!
//! The spring velocity of node i due to node j (eq:2-5) is
//! `vbar_ij = -k2 (1 - l0/l) (q_i - q_j) = -k2 (l - l0) u_ij`, `u_ij = (q_i - q_j) / l`.
//! The second form is used: it stays bounded as `l -> 0`, where `u_ij` is replaced by a
//! deterministic, antisymmetric direction (`+x` for the lower node index, `-x` for the other)
//! so that coincident nodes separate instead of producing NaN.

use crate::tray::TrayParams;
use crate::{ControlError, Vec2, Vec3};

/// Distances below this count as coincident nodes, m.
pub const COINCIDENT_M: f32 = 1e-4;

/// Identity of a node; the order `Uav(0) < .. < Uav(n-1) < Load < Center` breaks ties.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum NodeId {
    /// UAV i's node.
    Uav(usize),
    /// The load node `l`.
    Load,
    /// The tray centre `u`.
    Center,
}

/// True when eq:2-5's connection matrix links `a` and `b` (`w_ab = 1`).
pub fn connected(a: NodeId, b: NodeId) -> bool {
    match (a, b) {
        (NodeId::Uav(i), NodeId::Uav(j)) => i != j,
        (NodeId::Uav(_), _) | (_, NodeId::Uav(_)) => true,
        _ => false,
    }
}

/// The team size the paper's spring gain was chosen for (its simulation's ten UAVs, REFERENCE §5).
pub const PAPER_TEAM_SIZE: usize = 10;

/// The spring gain a team of `n` UAVs flies, 1/s: `k2` up to the paper's ten UAVs and
/// `k2 * 10 / n` beyond (extension; docs/design.md, "The spring gain of large teams").
///
/// Every UAV node has a spring to every other node (eq:2-5), so the formation's stiffest mode
/// grows with the team, about `k2 n / 2` (`5 /s` for the paper's ten at `k2 = 1`). Behind the
/// rigid body's actuation lag a team of 20-25 crosses the stability limit of that delayed loop
/// and surges fore and aft through the speed limit (a limit cycle; docs/robustness.md): the
/// scaled gain holds the stiffest mode at the paper team's. Prop. 1 holds for any positive
/// gain, so the dissipativity argument is unchanged. `k2` is taken as validated
/// ([`crate::DissipativeParams::validate`] rejects a non-finite or non-positive gain).
#[inline]
pub fn team_spring_gain(k2: f32, n: usize) -> f32 {
    if n > PAPER_TEAM_SIZE {
        k2 * (PAPER_TEAM_SIZE as f32 / n as f32)
    } else {
        k2
    }
}

/// The actuation lag the paper team's spring gain is held against, s: the observer lag of the
/// paper's 2 kg airframe behind PX4's stock rate gains (`VL_ACT_LAG`, identified by the
/// calibration hover; docs/design.md, "The observer's lag matched to each airframe").
pub const PAPER_ACTUATION_LAG_S: f32 = 0.08;

/// The share of the spring gain an airframe whose thrust follows its command with the lag
/// `lag_s` (s, the velocity loop's `VL_ACT_LAG`) flies: 1 up to [`PAPER_ACTUATION_LAG_S`],
/// `PAPER_ACTUATION_LAG_S / lag_s` beyond (extension; docs/design.md, "The spring gain of large
/// teams", "... and of slow airframes"). The formation's stiffest mode behind a delay is stable
/// while its rate times the delay stays small; this holds that product at the paper team's, as
/// [`team_spring_gain`] holds the rate for large teams. Behind the stock gains the 1.47 kg
/// airframe (0.101 s) flies 0.79 of it, the 4 kg one (0.142 s) 0.56: at the full gain sixteen
/// 4 kg UAVs breathed radially at 1.3 Hz, +-0.1 m, in calm air. A lag that is not finite and
/// positive gives 1.
#[inline]
pub fn lag_spring_scale(lag_s: f32) -> f32 {
    if lag_s > PAPER_ACTUATION_LAG_S && vt_fpu::is_finite(lag_s) { PAPER_ACTUATION_LAG_S / lag_s } else { 1.0 }
}

/// The actuation lag the springs are held against while the load heaves, s: 0.7 x
/// [`PAPER_ACTUATION_LAG_S`] ([`heave_spring_share`]).
pub const HEAVE_ACTUATION_LAG_S: f32 = 0.056;

/// The share of the flown spring gain a team flies while its load's altitude is being changed
/// (lift, climb, descent), for the actuation lag `lag_s` (s, `VL_ACT_LAG`): 1 up to
/// [`HEAVE_ACTUATION_LAG_S`], then `HEAVE_ACTUATION_LAG_S / lag_s` over [`lag_spring_scale`]
/// (0.7 from the paper's 0.08 s on; extension, docs/design.md, "The springs while the load
/// heaves"). A lag that is not finite and positive gives 1.
#[inline]
pub fn heave_spring_share(lag_s: f32) -> f32 {
    if lag_s > HEAVE_ACTUATION_LAG_S && vt_fpu::is_finite(lag_s) {
        vt_fpu::min(HEAVE_ACTUATION_LAG_S / lag_s / lag_spring_scale(lag_s), 1.0)
    } else {
        1.0
    }
}

/// Spring velocity of node `i` at `q_i` due to node `j` at `q_j` (eq:2-5), m/s, and whether
/// the nodes coincided. `i_first` is `id_i < id_j` (tie-break direction).
#[inline]
pub fn spring_velocity(q_i: &Vec2, q_j: &Vec2, rest_m: f32, k2: f32, i_first: bool) -> (Vec2, bool) {
    let d = q_i - q_j;
    let l = vt_fpu::sqrt(d.norm_squared());
    if l >= COINCIDENT_M {
        (d * (-k2 * (l - rest_m) / l), false)
    } else {
        let u = if i_first { Vec2::new(1.0, 0.0) } else { Vec2::new(-1.0, 0.0) };
        (u * (-k2 * (l - rest_m)), true)
    }
}

/// Velocity of UAV `id` at `own_m`, moving at `own_vel_mps`, from the dashpots beside its
/// springs to the neighbours at `neighbours_m` (by UAV id; `None`: not seen) moving at
/// `neighbours_vel_mps` (horizontal, by UAV id), gain `c` (dimensionless), m/s (extension;
/// docs/design.md, "A dashpot beside the springs of a team near its capacity"):
/// `-c sum_j ((v_i - v_j) . u_ij) u_ij`, `u_ij` the horizontal unit vector from UAV `j` to
/// UAV `i`.
///
/// Each dashpot acts along its pair's line, as its spring does, and on the pair's relative
/// velocity alone: a team moving as one feels nothing. Prop. 1's storage function still
/// decreases: for UAVs that follow their commands the dashpots make eq:2-16
/// `(I + c L_u) v = -grad V`, with `L_u = sum_pairs (e_i - e_j)(e_i - e_j)^T (x) u_ij u_ij^T`
/// positive semi-definite, so `dV/dt = -v^T (I + c L_u) v <= 0`. A pair closer than
/// [`COINCIDENT_M`] horizontally (no line), a neighbour without a velocity and a non-finite
/// velocity add nothing.
pub fn dashpot_velocity(id: usize, own_m: &Vec3, own_vel_mps: &Vec3, neighbours_m: &[Option<Vec3>], neighbours_vel_mps: &[Vec2], c: f32) -> Vec2 {
    let own_xy = own_m.xy();
    let own_vel = own_vel_mps.xy();
    let mut v = Vec2::zeros();
    for (j, (p_j, v_j)) in neighbours_m.iter().zip(neighbours_vel_mps.iter()).enumerate() {
        let Some(p_j) = p_j else { continue };
        if j == id {
            continue;
        }
        let d = own_xy - p_j.xy();
        let l2 = d.norm_squared();
        if l2 >= COINCIDENT_M * COINCIDENT_M {
            let rel = own_vel - v_j;
            // `((v_i - v_j) . d) d / |d|^2`: one division, no root.
            let push = d * (-c * rel.dot(&d) / l2);
            if vt_fpu::all_finite(&push) {
                v += push;
            }
        }
    }
    v
}

/// The take-off formation: node positions that define the rest lengths (eq:2-7).
#[derive(Debug, Clone, PartialEq)]
pub struct Formation<const N: usize> {
    n: usize,
    uav_nodes_m: [Vec2; N],
    load_node_m: Vec2,
    center_node_m: Vec2,
}

impl<const N: usize> Formation<N> {
    /// Formation from take-off UAV positions and the load position (nodes by eq:2-4).
    ///
    /// # Errors
    /// [`ControlError::TooManyUavs`], [`ControlError::BadTakeoff`] (non-finite, or a UAV not
    /// above the load by at least the tray's height floor), or an invalid `tray`.
    pub fn from_takeoff(uav_pos_m: &[Vec3], load_pos_m: &Vec3, tray: &TrayParams) -> Result<Self, ControlError> {
        tray.validate()?;
        if uav_pos_m.len() > N {
            return Err(ControlError::TooManyUavs { capacity: N });
        }
        if !vt_fpu::all_finite(load_pos_m) {
            return Err(ControlError::BadTakeoff { index: 0 });
        }
        let mut nodes = [Vec2::zeros(); N];
        for (i, (p, slot)) in uav_pos_m.iter().zip(nodes.iter_mut()).enumerate() {
            let (q, floored) = tray.project(p, load_pos_m);
            if !vt_fpu::all_finite(p) || floored {
                return Err(ControlError::BadTakeoff { index: i });
            }
            *slot = q;
        }
        Self::from_nodes(nodes.get(..uav_pos_m.len()).unwrap_or(&[]), load_pos_m.xy())
    }

    /// Formation from node positions directly (e.g. a designed formation); the tray centre
    /// is the centroid of the UAV nodes.
    ///
    /// # Errors
    /// [`ControlError::TooManyUavs`]; [`ControlError::BadTakeoff`] for non-finite nodes or
    /// an empty team.
    pub fn from_nodes(uav_nodes_m: &[Vec2], load_node_m: Vec2) -> Result<Self, ControlError> {
        if uav_nodes_m.len() > N {
            return Err(ControlError::TooManyUavs { capacity: N });
        }
        if uav_nodes_m.is_empty() {
            return Err(ControlError::BadTakeoff { index: 0 });
        }
        let mut nodes = [Vec2::zeros(); N];
        let mut sum = Vec2::zeros();
        for (i, (q, slot)) in uav_nodes_m.iter().zip(nodes.iter_mut()).enumerate() {
            if !(q.x.is_finite() && q.y.is_finite()) {
                return Err(ControlError::BadTakeoff { index: i });
            }
            *slot = *q;
            sum += q;
        }
        if !(load_node_m.x.is_finite() && load_node_m.y.is_finite()) {
            return Err(ControlError::BadTakeoff { index: 0 });
        }
        let center = sum / uav_nodes_m.len() as f32;
        Ok(Self { n: uav_nodes_m.len(), uav_nodes_m: nodes, load_node_m, center_node_m: center })
    }

    /// Number of UAVs.
    pub fn n_uavs(&self) -> usize {
        self.n
    }

    /// Take-off position of a node, m (an out-of-range UAV index gives the tray centre).
    pub fn node_m(&self, id: NodeId) -> Vec2 {
        match id {
            NodeId::Uav(i) if i < self.n => self.uav_nodes_m.get(i).copied().unwrap_or(self.center_node_m),
            NodeId::Uav(_) | NodeId::Center => self.center_node_m,
            NodeId::Load => self.load_node_m,
        }
    }

    /// Rest length `l_ab0` (eq:2-7), m.
    pub fn rest_length_m(&self, a: NodeId, b: NodeId) -> f32 {
        vt_fpu::norm(&(self.node_m(a) - self.node_m(b)))
    }

    /// Spring energy `sum over connected pairs of 1/2 (l - l0)^2` (eq:2-8), m^2, for the
    /// node positions `uav_m`, `load_m`, `center_m`.
    pub fn energy(&self, uav_m: &[Vec2], load_m: &Vec2, center_m: &Vec2) -> f32 {
        let mut e = 0.0;
        for (i, qi) in uav_m.iter().enumerate().take(self.n) {
            for (j, qj) in uav_m.iter().enumerate().take(self.n).skip(i + 1) {
                e += half_sq(vt_fpu::norm(&(qi - qj)) - self.rest_length_m(NodeId::Uav(i), NodeId::Uav(j)));
            }
            e += half_sq(vt_fpu::norm(&(qi - load_m)) - self.rest_length_m(NodeId::Uav(i), NodeId::Load));
            e += half_sq(vt_fpu::norm(&(qi - center_m)) - self.rest_length_m(NodeId::Uav(i), NodeId::Center));
        }
        e
    }
}

#[inline]
fn half_sq(x: f32) -> f32 {
    0.5 * x * x
}


#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    /// The dashpots act on relative motion along each pair's line alone: nothing for a team
    /// moving as one or for motion across the line; against a pair closing or opening along it,
    /// by `c` times that speed; equal and opposite on the pair's two UAVs; never adding energy
    /// (`(v_i - v_j) . push <= 0`); nothing for a neighbour unseen, coincident or with a velocity
    /// that is not a number, or with no velocities at all.
    #[test]
    fn the_dashpots_damp_a_pair_s_relative_motion_along_its_line_alone() {
        let c = 0.1;
        let a = Vec3::new(0.0, 0.0, 5.0);
        let b = Vec3::new(2.0, 0.0, 6.0);
        let nb = [Some(a), Some(b)];
        let dash = |id: usize, own: &Vec3, v_own: Vec2, v: [Vec2; 2]| dashpot_velocity(id, own, &Vec3::new(v_own.x, v_own.y, 0.0), &nb, &v, c);
        // As one: nothing.
        let v = Vec2::new(0.7, -0.4);
        assert_eq!(dash(0, &a, v, [v, v]), Vec2::zeros());
        // Across the line (y): nothing.
        assert_relative_eq!(dash(0, &a, Vec2::new(0.0, 0.5), [Vec2::new(0.0, 0.5), Vec2::new(0.0, -0.5)]), Vec2::zeros(), epsilon = 1e-7);
        // UAV 0 closing on UAV 1 at 0.5 m/s along the line: pushed back by c * 0.5; UAV 1, at
        // rest, pulled towards it by as much: equal and opposite.
        let v_a = Vec2::new(0.5, 0.0);
        let on_a = dash(0, &a, v_a, [v_a, Vec2::zeros()]);
        let on_b = dash(1, &b, Vec2::zeros(), [v_a, Vec2::zeros()]);
        assert_relative_eq!(on_a, Vec2::new(-0.05, 0.0), epsilon = 1e-7);
        assert_relative_eq!(on_b, -on_a, epsilon = 1e-7);
        // Dissipative for any velocities.
        for k in 0..50 {
            let t = k as f32 * 0.37;
            let (va, vb) = (Vec2::new(t.cos(), (2.0 * t).sin()), Vec2::new((3.0 * t).sin(), t.cos() * 0.5));
            let push = dash(0, &a, va, [va, vb]);
            assert!((va - vb).dot(&push) <= 0.0, "{k}");
        }
        // Degenerate inputs add nothing.
        let zero = Vec2::zeros();
        assert_eq!(dashpot_velocity(0, &a, &Vec3::new(0.5, 0.0, 0.0), &[Some(a), None], &[zero, zero], c), zero);
        assert_eq!(dashpot_velocity(0, &a, &Vec3::new(0.5, 0.0, 0.0), &[Some(a), Some(Vec3::new(0.0, 0.0, 7.0))], &[zero, zero], c), zero);
        assert_eq!(dashpot_velocity(0, &a, &Vec3::new(0.5, 0.0, 0.0), &nb, &[zero, Vec2::new(f32::NAN, 0.0)], c), zero);
        assert_eq!(dashpot_velocity(0, &a, &Vec3::new(0.5, 0.0, 0.0), &nb, &[], c), zero);
        assert_eq!(dashpot_velocity(0, &a, &Vec3::new(0.5, 0.0, 0.0), &nb, &[zero, zero], 0.0), zero);
    }

    const K2: f32 = 1.0;

    #[test]
    fn the_spring_gain_is_the_papers_up_to_ten_uavs_and_scaled_by_ten_over_n_beyond() {
        for n in 1..=PAPER_TEAM_SIZE {
            assert_eq!(team_spring_gain(0.7, n), 0.7);
        }
        assert_eq!(team_spring_gain(1.0, 20), 0.5);
        // scale-100uav.toml's gain, k2 = 0.1 by hand before the rule: the same bits.
        assert_eq!(team_spring_gain(1.0, 100), 0.1);
        // The formation's stiffest mode, about k2 n / 2, stays at the paper team's 5 /s.
        for n in 11..=64 {
            let mode = team_spring_gain(1.0, n) * n as f32 / 2.0;
            assert_relative_eq!(mode, 5.0, epsilon = 1e-5);
            assert!(team_spring_gain(1.0, n) < team_spring_gain(1.0, n - 1));
        }
    }

    #[test]
    fn a_slow_airframe_flies_the_spring_gain_that_holds_the_paper_team_s_mode_times_lag() {
        assert_eq!(lag_spring_scale(0.05), 1.0, "the scenario world's tuned lag");
        assert_eq!(lag_spring_scale(PAPER_ACTUATION_LAG_S), 1.0, "the paper airframe: the same bits");
        assert_relative_eq!(lag_spring_scale(0.1415), 0.5654, epsilon = 1e-4);
        for bad in [f32::NAN, f32::INFINITY, -0.2, 0.0] {
            assert_eq!(lag_spring_scale(bad), 1.0, "{bad}");
        }
        // The stiffest mode times the lag never exceeds the paper team's, 5 /s x 0.08 s.
        for n in 1..=40 {
            for lag in [0.02f32, 0.08, 0.1, 0.1415, 0.3] {
                let k2 = team_spring_gain(1.0, n) * lag_spring_scale(lag);
                assert!(k2 * n as f32 / 2.0 * lag <= 5.0 * PAPER_ACTUATION_LAG_S * (1.0 + 1e-5), "n {n}, lag {lag}: k2 {k2}");
            }
        }
    }

    /// While the load heaves the springs hold the stiffest mode times the lag at 0.7 of the
    /// paper team's: 0.7 on the paper airframe behind the stock gains, on top of the slow
    /// airframes' own scale; nothing changes at the scenarios' tuned lag.
    #[test]
    fn a_heaving_load_flies_the_springs_at_the_heave_lag() {
        assert_eq!(heave_spring_share(0.05), 1.0, "the scenario world's tuned lag: the same bits");
        assert_eq!(heave_spring_share(HEAVE_ACTUATION_LAG_S), 1.0);
        assert_relative_eq!(heave_spring_share(PAPER_ACTUATION_LAG_S), 0.7, epsilon = 1e-6);
        assert_relative_eq!(heave_spring_share(0.1415), 0.7, epsilon = 1e-6);
        assert_relative_eq!(heave_spring_share(0.068), 0.056 / 0.068, epsilon = 1e-6);
        for bad in [f32::NAN, f32::INFINITY, -0.2, 0.0] {
            assert_eq!(heave_spring_share(bad), 1.0, "{bad}");
        }
        for n in 1..=40 {
            for lag in [0.02f32, 0.056, 0.07, 0.08, 0.1, 0.1415, 0.3] {
                let share = heave_spring_share(lag);
                assert!(share > 0.0 && share <= 1.0, "lag {lag}: {share}");
                let k2 = team_spring_gain(1.0, n) * lag_spring_scale(lag) * share;
                assert!(k2 * n as f32 / 2.0 * lag <= 5.0 * HEAVE_ACTUATION_LAG_S * (1.0 + 1e-5), "n {n}, lag {lag}: k2 {k2}");
            }
        }
    }

    /// Spring-only velocity field of every node (all nodes free), in the order UAVs, l, u.
    fn spring_field<const N: usize>(f: &Formation<N>, nodes: &[(NodeId, Vec2)]) -> Vec<Vec2> {
        nodes
            .iter()
            .map(|(a, qa)| {
                nodes
                    .iter()
                    .filter(|(b, _)| connected(*a, *b))
                    .map(|(b, qb)| spring_velocity(qa, qb, f.rest_length_m(*a, *b), K2, a < b).0)
                    .sum()
            })
            .collect()
    }

    fn energy_of<const N: usize>(f: &Formation<N>, nodes: &[(NodeId, Vec2)]) -> f32 {
        let n = f.n_uavs();
        let uavs: Vec<Vec2> = nodes[..n].iter().map(|x| x.1).collect();
        f.energy(&uavs, &nodes[n].1, &nodes[n + 1].1)
    }

    #[test]
    fn connection_matrix_matches_eq_2_5() {
        use NodeId::*;
        assert!(connected(Uav(0), Uav(1)));
        assert!(!connected(Uav(2), Uav(2)));
        assert!(connected(Uav(0), Load) && connected(Center, Uav(3)));
        assert!(!connected(Load, Center) && !connected(Center, Load));
    }

    #[test]
    fn spring_by_hand() {
        // Stretched: l = 2, l0 = 1 -> node i pulled towards j at k2 (l - l0) = 1 m/s.
        let (v, c) = spring_velocity(&Vec2::new(2.0, 0.0), &Vec2::zeros(), 1.0, 1.0, true);
        assert!(!c);
        assert_relative_eq!(v, Vec2::new(-1.0, 0.0), epsilon = 1e-6);
        // Compressed: l = 0.5, l0 = 1 -> pushed away at 0.5 m/s.
        let (v, _) = spring_velocity(&Vec2::new(0.0, 0.5), &Vec2::zeros(), 1.0, 1.0, true);
        assert_relative_eq!(v, Vec2::new(0.0, 0.5), epsilon = 1e-6);
    }

    #[test]
    fn coincident_nodes_separate_antisymmetrically() {
        let q = Vec2::new(3.0, 4.0);
        let (vi, ci) = spring_velocity(&q, &q, 2.0, 1.0, true);
        let (vj, cj) = spring_velocity(&q, &q, 2.0, 1.0, false);
        assert!(ci && cj);
        assert_relative_eq!(vi, Vec2::new(2.0, 0.0), epsilon = 1e-6);
        assert_relative_eq!(vi, -vj, epsilon = 1e-6);
    }

    #[test]
    fn zero_rest_length_spring_is_finite_at_contact() {
        let q = Vec2::new(1.0, 1.0);
        let (v, c) = spring_velocity(&q, &q, 0.0, 1.0, true);
        assert!(c);
        assert_eq!(v, Vec2::zeros());
    }

    #[test]
    fn takeoff_formation_rest_lengths() {
        // Four UAVs 8 m above the load on a 2.4 m circle: nodes on a 3 m circle (H = 10).
        let load = Vec3::new(0.0, 0.0, 1.0);
        let uavs = [
            Vec3::new(2.4, 0.0, 9.0),
            Vec3::new(0.0, 2.4, 9.0),
            Vec3::new(-2.4, 0.0, 9.0),
            Vec3::new(0.0, -2.4, 9.0),
        ];
        let f = Formation::<8>::from_takeoff(&uavs, &load, &TrayParams::default()).unwrap();
        assert_relative_eq!(f.rest_length_m(NodeId::Uav(0), NodeId::Load), 3.0, epsilon = 1e-5);
        assert_relative_eq!(f.rest_length_m(NodeId::Uav(0), NodeId::Center), 3.0, epsilon = 1e-5);
        assert_relative_eq!(f.rest_length_m(NodeId::Uav(0), NodeId::Uav(2)), 6.0, epsilon = 1e-5);
        assert_relative_eq!(f.rest_length_m(NodeId::Uav(0), NodeId::Uav(1)), 3.0 * 2f32.sqrt(), epsilon = 1e-5);
    }

    #[test]
    fn bad_takeoffs_are_rejected() {
        let load = Vec3::zeros();
        let tray = TrayParams::default();
        let below = [Vec3::new(1.0, 0.0, 0.2)];
        assert_eq!(Formation::<4>::from_takeoff(&below, &load, &tray), Err(ControlError::BadTakeoff { index: 0 }));
        let nan = [Vec3::new(1.0, 0.0, 5.0), Vec3::new(f32::NAN, 0.0, 5.0)];
        assert_eq!(Formation::<4>::from_takeoff(&nan, &load, &tray), Err(ControlError::BadTakeoff { index: 1 }));
        let many = [Vec3::new(1.0, 0.0, 5.0); 5];
        assert_eq!(Formation::<4>::from_takeoff(&many, &load, &tray), Err(ControlError::TooManyUavs { capacity: 4 }));
    }

    fn random_setup() -> impl Strategy<Value = (Vec<Vec2>, Vec<Vec2>)> {
        (2usize..8).prop_flat_map(|n| {
            (
                proptest::collection::vec((-5f32..5.0, -5f32..5.0).prop_map(|(x, y)| Vec2::new(x, y)), n + 1),
                proptest::collection::vec((-6f32..6.0, -6f32..6.0).prop_map(|(x, y)| Vec2::new(x, y)), n + 2),
            )
        })
    }

    proptest! {
        /// Prop. 1: along the spring-only flow, dV/dt = -(1/k2) sum |v_i|^2 <= 0.
        #[test]
        fn spring_flow_never_increases_energy((takeoff, now) in random_setup()) {
            let n = takeoff.len() - 1;
            let f = Formation::<16>::from_nodes(&takeoff[..n], takeoff[n]).unwrap();
            let mut nodes: Vec<(NodeId, Vec2)> = (0..n).map(|i| (NodeId::Uav(i), now[i])).collect();
            nodes.push((NodeId::Load, now[n]));
            nodes.push((NodeId::Center, now[n + 1]));
            // Analytic derivative along the field.
            let v = spring_field(&f, &nodes);
            let mut dvdt = 0.0f32;
            for (a, (ia, qa)) in nodes.iter().enumerate() {
                for (b, (ib, qb)) in nodes.iter().enumerate().skip(a + 1) {
                    if connected(*ia, *ib) {
                        let d = qa - qb;
                        let l = d.norm();
                        if l > 1e-3 {
                            dvdt += (l - f.rest_length_m(*ia, *ib)) / l * d.dot(&(v[a] - v[b]));
                        }
                    }
                }
            }
            prop_assert!(dvdt <= 1e-4, "dV/dt = {}", dvdt);
            // And a small explicit-Euler step of the flow does not raise the energy.
            let e0 = energy_of(&f, &nodes);
            let dt = 1e-3;
            let stepped: Vec<(NodeId, Vec2)> = nodes.iter().zip(v.iter()).map(|((id, q), vi)| (*id, q + vi * dt)).collect();
            let e1 = energy_of(&f, &stepped);
            prop_assert!(e1 <= e0 + 1e-4 * (1.0 + e0), "energy rose: {} -> {}", e0, e1);
        }
    }

    #[test]
    fn spring_flow_restores_the_takeoff_shape() {
        // Squash a 6-node ring to an ellipse and let the springs act: the energy decays to ~0.
        let n = 6;
        let takeoff: Vec<Vec2> = (0..n)
            .map(|i| {
                let a = i as f32 / n as f32 * core::f32::consts::TAU;
                Vec2::new(3.0 * a.cos(), 3.0 * a.sin())
            })
            .collect();
        let f = Formation::<8>::from_nodes(&takeoff, Vec2::zeros()).unwrap();
        let mut nodes: Vec<(NodeId, Vec2)> =
            takeoff.iter().enumerate().map(|(i, q)| (NodeId::Uav(i), Vec2::new(q.x * 1.5, q.y * 0.4))).collect();
        nodes.push((NodeId::Load, Vec2::zeros()));
        nodes.push((NodeId::Center, Vec2::zeros()));
        let e0 = energy_of(&f, &nodes);
        let mut prev = e0;
        for _ in 0..4000 {
            let v = spring_field(&f, &nodes);
            for (node, vi) in nodes.iter_mut().zip(v.iter()) {
                node.1 += vi * 2e-3;
            }
            let e = energy_of(&f, &nodes);
            assert!(e <= prev + 1e-5);
            prev = e;
        }
        assert!(prev < 1e-3 * e0, "energy {e0} -> {prev}");
    }
}
