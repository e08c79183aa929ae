//! The world's side of issue 28: the UAVs' LiDAR scans of the true obstacles, and the
//! obstacles that appear in flight (`[[world.appear]]`), which the scans and the clearances
//! see from their time on.

use crate::lidar::Lidar;
use crate::map::Shape;
use crate::obstacles::Obstacles;
use crate::scenario::LoadedScenario;
use nalgebra::{Vector2, Vector3};
use vt_map::Scan;

/// The team's range sensors and the world they see.
#[derive(Debug, Clone)]
pub struct Scans {
    lidar: Option<Lidar>,
    truth: Obstacles,
    /// Obstacles still to appear: (plant step, shape), in time order.
    appear: Vec<(u64, Shape)>,
    next_appear: usize,
    /// A scan every this many high-level periods.
    every_hl: u64,
    /// Per UAV, this high-level period's scan (`None`: none taken).
    out: Vec<Option<Scan>>,
}

impl Scans {
    /// The sensors of `ls` for `n` UAVs (`None`: no LiDAR and nothing appears), noise stream of
    /// `seed`; `plant_hz` and `hl_hz` place scans and appearances in time.
    pub fn new(ls: &LoadedScenario, n: usize, seed: u64, plant_hz: f64, hl_hz: f64) -> Option<Self> {
        let s = &ls.scenario;
        if s.sensors.lidar.is_none() && s.world.appear.is_empty() {
            return None;
        }
        let every_hl = s.sensors.lidar.as_ref().map_or(1, |l| (hl_hz / l.rate_hz).round().max(1.0) as u64);
        let mut appear: Vec<(u64, Shape)> =
            s.world.appear.iter().filter_map(|a| a.shape().ok().map(|shape| ((a.time_s * plant_hz).round() as u64, shape))).collect();
        appear.sort_by_key(|a| a.0);
        Some(Self {
            lidar: s.sensors.lidar.clone().map(|l| Lidar::new(l, seed)),
            truth: Obstacles::of(ls),
            appear,
            next_appear: 0,
            every_hl,
            out: vec![None; n],
        })
    }

    /// At high-level period `hl_step`: each UAV's scan from its true position `true_m`,
    /// reported at the position it measured `measured_m` (none between scans).
    pub fn measure(&mut self, hl_step: u64, true_m: &[Vector3<f64>], measured_m: &[Vector3<f32>]) -> &[Option<Scan>] {
        let due = hl_step.is_multiple_of(self.every_hl);
        for (i, slot) in self.out.iter_mut().enumerate() {
            *slot = match (&mut self.lidar, due, true_m.get(i), measured_m.get(i)) {
                (Some(l), true, Some(t), Some(m)) => Some(l.scan(&self.truth, Vector2::new(t.x, t.y), Vector2::new(f64::from(m.x), f64::from(m.y)))),
                _ => None,
            };
        }
        &self.out
    }

    /// The scans of the last [`Self::measure`].
    pub fn last(&self) -> &[Option<Scan>] {
        &self.out
    }

    /// The obstacles that appear at plant step `step` or before and have not yet: each is added
    /// to what the LiDARs see and handed to `add` (the clearances).
    pub fn appear(&mut self, step: u64, mut add: impl FnMut(&Shape)) {
        while let Some((due, shape)) = self.appear.get(self.next_appear) {
            if *due > step {
                break;
            }
            self.truth.add(shape);
            add(shape);
            self.next_appear += 1;
        }
    }
}
