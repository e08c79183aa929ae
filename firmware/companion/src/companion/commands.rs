//! `COMMAND_LONG`: the mission's start (arming the flight, or the refusal with its reasons),
//! the operator's hold and resume, the abort, and the board's reboot and shutdown
//! (docs/protocol.md).

use mavlink::dialects::common::{MavCmd, MavResult, COMMAND_ACK_DATA, COMMAND_LONG_DATA};
use vt_dissipative::TeamMode;

use super::{Core, Io, Mode, Request, REBOOT, SHUTDOWN};
use crate::flight::{Flight, HoldReasons, StartError};
use crate::log;
use crate::params::Param;

impl Core<'_> {
    /// `MAV_CMD_MISSION_START`: arms the flight from the sources at the current time, or
    /// reports the refusal (`STATUSTEXT`, heartbeat).
    #[inline(never)] // its frame (Flight::start: ~6 KiB) must not merge into the receive task's (docs/firmware.md)
    pub(super) fn start(&mut self, io: &mut impl Io) -> Result<(), StartError> {
        let now = if self.params.get_u32(Param::Lockstep) == 1 { self.sources.own.map_or(self.clock_ms, |s| s.stamp_ms) } else { io.now_ms() };
        self.clock_ms = now;
        // Issue 28: `PR_MAP` 1 needs a map this build holds and the world fits.
        let started = if self.params.get_u32(Param::PrMap) == 1 && !self.map_on() {
            Err(StartError::NoMap)
        } else {
            Flight::start(&self.params, self.tube(), &self.sources, now)
        };
        match started {
            Ok(fl) => {
                self.phase_sent = fl.phase() as u8;
                self.flight = Some(fl);
                self.refusal = 0;
                self.hl_steps = 0;
                self.team_mode_sent = TeamMode::Transport;
                log!(info, "mission started: UAV {} of {}", self.params.get_u32(Param::Id), self.params.get_u32(Param::NUavs));
                Ok(())
            }
            Err(e) => {
                log!(warn, "mission start refused: {}", e);
                self.refused(&e, io);
                Err(e)
            }
        }
    }

    pub(super) fn on_command(&mut self, d: &COMMAND_LONG_DATA, io: &mut impl Io) {
        let result = match d.command {
            MavCmd::MAV_CMD_MISSION_START if self.flight.is_some() => MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
            MavCmd::MAV_CMD_MISSION_START => match self.start(io) {
                Ok(()) => MavResult::MAV_RESULT_ACCEPTED,
                Err(StartError::StaleData) => MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
                Err(StartError::Infeasible(_) | StartError::Wind(_)) => MavResult::MAV_RESULT_DENIED,
                Err(_) => MavResult::MAV_RESULT_FAILED,
            },
            // Operator hold and resume (docs/protocol.md): param1 0 pause, 1 continue.
            MavCmd::MAV_CMD_DO_PAUSE_CONTINUE => match (self.flight.as_mut(), d.param1) {
                (Some(fl), p) if p == 0.0 || p == 1.0 => {
                    fl.set_operator_hold(p == 0.0);
                    MavResult::MAV_RESULT_ACCEPTED
                }
                (Some(_), _) => MavResult::MAV_RESULT_DENIED,
                (None, _) => MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
            },
            // Abort (docs/protocol.md): the companion stops commanding; the autopilot's own
            // setpoint-loss action takes over (docs/deploy.md). The team is told to hold first.
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM if d.param1 == 0.0 => match self.flight.as_mut() {
                Some(fl) => {
                    fl.set_operator_hold(true);
                    self.mode = Mode::Hold;
                    self.send_heartbeat_with(io, HoldReasons::OPERATOR);
                    self.flight = None;
                    MavResult::MAV_RESULT_ACCEPTED
                }
                None => MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
            },
            MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN if d.param1 == REBOOT => {
                self.request = Some(Request::Reboot);
                MavResult::MAV_RESULT_ACCEPTED
            }
            MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN if d.param1 == SHUTDOWN => {
                self.request = Some(Request::Shutdown);
                MavResult::MAV_RESULT_ACCEPTED
            }
            _ => MavResult::MAV_RESULT_UNSUPPORTED,
        };
        self.update_mode();
        self.send(io, &COMMAND_ACK_DATA { command: d.command, result });
    }
}
