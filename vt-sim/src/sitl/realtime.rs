//! `--realtime`: the simulator keeps simulated time on the wall clock, as PX4 SITL without
//! lockstep does. The companions run their own Tickers (`VT_LOCKSTEP = 0`) on their own clocks;
//! the simulator streams each UAV's state every low-level period (`SYSTEM_TIME` every
//! high-level period for their clock offset) and flies whatever setpoint arrived last. Nothing
//! is bit-comparable here (two clocks); the mission has to succeed with its floors.

use super::udp::UdpPort;
use crate::mission::{Setpoint, Team, TeamStart, Tick};
use crate::lockstep::{Encoder, PortTeam, Rx};
use crate::scenario::LoadedScenario;
use crate::sim::SimError;
use mavlink::dialects::common::{MavCmd, SYSTEM_TIME_DATA};
use nalgebra::Vector3;
use std::time::{Duration, Instant};
use vt_companion::AUTOPILOT_COMPONENT_ID;

/// How long the start waits for every companion's acknowledgement and first setpoint, when a
/// program starts them (`host-sim sitl`).
pub const START_TIMEOUT: Duration = Duration::from_secs(10);

/// The companions behind UDP ports, on the wall clock.
pub struct RealtimeTeam<'p> {
    inner: PortTeam<'p, UdpPort>,
    /// Wall instant of simulated time `anchor.1` (ms).
    anchor: Option<(Instant, u32)>,
    latest: Vec<Option<Setpoint>>,
    /// Per UAV: a setpoint arrived since the last period (reused buffer).
    arrived: Vec<bool>,
    /// Each UAV's system id (`VT_SYSID_BASE + i`, as the companions are configured).
    sysids: Vec<u8>,
    clock: Vec<Encoder>,
    /// Low-level periods in which no new setpoint had arrived from a UAV.
    pub stale_periods: u64,
    /// The worst lag of the simulator behind the wall clock, s.
    pub worst_lag_s: f64,
    start_timeout: Duration,
}

impl<'p> RealtimeTeam<'p> {
    /// Wraps a configured team whose start hook starts the companions.
    pub fn new(inner: PortTeam<'p, UdpPort>, n: usize) -> Self {
        Self {
            inner,
            anchor: None,
            latest: vec![None; n],
            arrived: vec![false; n],
            sysids: (0..n).map(|i| crate::companion::SYSID_BASE.saturating_add(i.min(255) as u8)).collect(),
            clock: (0..n).map(|_| Encoder::default()).collect(),
            stale_periods: 0,
            worst_lag_s: 0.0,
            start_timeout: START_TIMEOUT,
        }
    }

    /// Waits this long for the start (a person at a ground station: minutes).
    #[must_use]
    pub fn with_start_timeout(mut self, t: Duration) -> Self {
        self.start_timeout = t;
        self
    }

    /// Sends every companion its share of `tick` (with what the team network relays: issue
    /// 28's scans and offers), then `SYSTEM_TIME` at high-level ticks.
    fn send(&mut self, tick: &Tick<'_>) -> Result<(), SimError> {
        self.inner.open(tick);
        for i in 0..self.latest.len() {
            let mut bytes = self.inner.frames_for(i, tick);
            if tick.high_level {
                let st = SYSTEM_TIME_DATA { time_unix_usec: 0, time_boot_ms: tick.time_ms };
                bytes.extend(self.clock[i].frame(self.sysids.get(i).copied().unwrap_or(0), AUTOPILOT_COMPONENT_ID, &st));
            }
            use crate::lockstep::Port;
            self.inner.ports_mut()[i].send(&bytes).map_err(|e| SimError(format!("UAV {i}: {e}")))?;
        }
        Ok(())
    }

    /// Sleeps until the wall clock reaches simulated time `time_ms`.
    fn pace(&mut self, time_ms: u32) {
        let (t0, ms0) = *self.anchor.get_or_insert((Instant::now(), time_ms));
        let target = t0 + Duration::from_millis(u64::from(time_ms.saturating_sub(ms0)));
        let now = Instant::now();
        if let Some(wait) = target.checked_duration_since(now) {
            std::thread::sleep(wait);
        } else {
            self.worst_lag_s = self.worst_lag_s.max(now.duration_since(target).as_secs_f64());
        }
    }

    /// Takes everything waiting, keeping each UAV's newest setpoint.
    fn drain(&mut self) -> Result<(), SimError> {
        for i in 0..self.latest.len() {
            loop {
                let rx = self.inner.ports_mut()[i].poll(Duration::ZERO).map_err(|e| SimError(e.0))?;
                if let Some(r) = &rx {
                    self.inner.frame_seen(i, r);
                }
                match rx {
                    Some(Rx::Setpoint { q, thrust, .. }) => {
                        self.latest[i] = Some(Setpoint { q_ned: q, thrust });
                        self.arrived[i] = true;
                    }
                    Some(other) => self.inner.note(i, other),
                    None => break,
                }
            }
        }
        Ok(())
    }
}

impl Team for RealtimeTeam<'_> {
    fn preflight(&mut self, ls: &LoadedScenario, at: &TeamStart<'_>) -> Result<(), SimError> {
        self.inner.relay_for(ls)?;
        self.send(&at.tick)?;
        self.pace(at.tick.time_ms);
        self.drain()?;
        self.inner.close(&at.tick, true);
        Ok(())
    }

    fn start(&mut self, ls: &LoadedScenario, start: &TeamStart<'_>) -> Result<Option<String>, SimError> {
        self.inner.relay_for(ls)?;
        self.send(&start.tick)?;
        let mut hook = self.inner.take_start_hook().ok_or_else(|| SimError("realtime: nobody starts the companions".into()))?;
        hook().map_err(|e| SimError(format!("the start failed: {e}")))?;
        // Acknowledgements and a first setpoint from each, the states kept fresh meanwhile
        // (simulated time stands still: the plant is not stepped).
        let t0 = Instant::now();
        let mut acked = vec![false; self.latest.len()];
        while !(acked.iter().all(|a| *a) && self.latest.iter().all(Option::is_some)) {
            if t0.elapsed() > self.start_timeout {
                return Err(SimError(format!("realtime start: acknowledged {acked:?}, first setpoints {:?}", self.latest.iter().map(Option::is_some).collect::<Vec<_>>())));
            }
            self.send(&start.tick)?;
            std::thread::sleep(Duration::from_millis(2));
            for (i, a) in acked.iter_mut().enumerate() {
                while let Some(rx) = self.inner.ports_mut()[i].poll(Duration::ZERO).map_err(|e| SimError(e.0))? {
                    match rx {
                        Rx::CommandAck(c, r) if c == MavCmd::MAV_CMD_MISSION_START as u32 => {
                            if r != 0 {
                                return Ok(Some(format!("UAV {i}: mission start refused (MAV_RESULT {r})")));
                            }
                            *a = true;
                        }
                        Rx::Setpoint { q, thrust, .. } => self.latest[i] = Some(Setpoint { q_ned: q, thrust }),
                        other => self.inner.absorb(i, &other),
                    }
                }
            }
        }
        self.inner.close(&start.tick, true);
        // Simulated time starts now.
        self.anchor = Some((Instant::now(), start.tick.time_ms));
        Ok(None)
    }

    fn step(&mut self, tick: &Tick<'_>, out: &mut [Setpoint]) -> Result<(), SimError> {
        self.send(tick)?;
        self.pace(tick.time_ms);
        self.arrived.iter_mut().for_each(|a| *a = false);
        self.drain()?;
        self.inner.close(tick, false);
        for ((o, l), a) in out.iter_mut().zip(&self.latest).zip(&self.arrived) {
            if let Some(sp) = l {
                *o = *sp;
            }
            self.stale_periods += u64::from(!a);
        }
        Ok(())
    }

    fn holding(&self) -> Vec<bool> {
        self.inner.holding()
    }

    fn refusal_text(&self, uav: usize) -> Option<String> {
        self.inner.refusal_text(uav)
    }

    fn team_modes(&self, out: &mut [vt_dissipative::TeamMode]) {
        self.inner.team_modes(out);
    }

    fn phases(&self, phases: &mut [u8], refusals: &mut [u8]) {
        self.inner.phases(phases, refusals);
    }

    fn controller_outputs(&self, _vel_cmd_mps: &mut [Vector3<f32>], _f_hat_n: &mut [Vector3<f32>]) {}

    fn published_tube(&self) -> Option<(u32, &crate::scenario::SimTube)> {
        self.inner.published_tube()
    }

    fn replan_stats(&self) -> Option<crate::mission::replan::ReplanStats> {
        self.inner.replan_stats()
    }
}
