//! What the companion tells the team and the ground station besides the control outputs:
//! `HEARTBEAT` (mode, hold reasons, refusal code), `SYS_STATUS` and the stack mark, the ground
//! station's status (data ages, clearance), refusals as `STATUSTEXT`, `PARAM_VALUE`
//! (docs/protocol.md, "Outputs").

use mavlink::dialects::common::{
    MavAutopilot, MavModeFlag, MavParamType, MavSeverity, MavState, MavSysStatusSensor, MavType, DEBUG_VECT_DATA, HEARTBEAT_DATA,
    NAMED_VALUE_FLOAT_DATA, NAMED_VALUE_INT_DATA, PARAM_VALUE_DATA, STATUSTEXT_DATA, SYS_STATUS_DATA,
};

use super::{Core, Io, Mode, NAME_AGES, NAME_CLEARANCE, NAME_STACK};
use crate::flight::StartError;
use crate::params::{self, Param};

impl Core<'_> {
    pub(super) fn send_heartbeat(&mut self, io: &mut impl Io) {
        let reasons = self.flight.as_ref().map_or(0, |f| f.hold_reasons().0);
        self.send_heartbeat_with(io, reasons);
    }

    pub(super) fn send_heartbeat_with(&mut self, io: &mut impl Io, reasons: u8) {
        let phase = self.flight.as_ref().map_or(0, |f| f.phase() as u8);
        self.beacon = u32::from(self.mode as u8) | (u32::from(reasons) << 8) | (u32::from(self.refusal) << 16) | (u32::from(phase) << 24);
        let system_status = match self.mode {
            Mode::Unconfigured | Mode::Ready => MavState::MAV_STATE_STANDBY,
            Mode::Transport => MavState::MAV_STATE_ACTIVE,
            Mode::Hold | Mode::TeamHold => MavState::MAV_STATE_CRITICAL,
        };
        self.send(
            io,
            &HEARTBEAT_DATA {
                custom_mode: self.beacon,
                mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
                autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
                base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                system_status,
                mavlink_version: 3,
            },
        );
    }

    pub(super) fn send_status(&mut self, io: &mut impl Io) {
        self.send_heartbeat(io);
        let c = self.link;
        let sat = |x: u32| x.min(u32::from(u16::MAX)) as u16;
        self.send(
            io,
            &SYS_STATUS_DATA {
                onboard_control_sensors_present: MavSysStatusSensor::empty(),
                onboard_control_sensors_enabled: MavSysStatusSensor::empty(),
                onboard_control_sensors_health: MavSysStatusSensor::empty(),
                load: 0,
                voltage_battery: u16::MAX,
                current_battery: -1,
                drop_rate_comm: 0,
                errors_comm: sat(c.crc_errors.wrapping_add(c.framing_errors)),
                errors_count1: sat(c.unknown_ids),
                errors_count2: sat(self.values.bad_values),
                errors_count3: sat(c.overruns),
                errors_count4: sat(c.bytes_discarded),
                battery_remaining: -1,
            },
        );
        let stack = io.stack_used_bytes();
        self.send(io, &NAMED_VALUE_INT_DATA { time_boot_ms: self.clock_ms, value: stack as i32, name: NAME_STACK.into() });
        if io.wants_frames() {
            self.send_team_status(io);
        }
    }

    /// The ground station's live status (docs/protocol.md): data ages and the own clearance.
    pub(super) fn send_team_status(&mut self, io: &mut impl Io) {
        let (n, id) = (self.params.get_u32(Param::NUavs) as usize, self.params.get_u32(Param::Id) as usize);
        let [own, load, team] = self.sources.ages_ms(self.clock_ms, n, id);
        let time_usec = u64::from(self.clock_ms) * 1000;
        self.send(io, &DEBUG_VECT_DATA { time_usec, x: own as f32, y: load as f32, z: team as f32, name: NAME_AGES.into() });
        let clearance = match (self.tube(), self.sources.own) {
            (Some(tube), Some(own)) => {
                let q = own.value.pos_m.xy();
                tube.locate(q, 0).map(|s| s.boundary_distance_m(q))
            }
            _ => None,
        };
        if let Some(value) = clearance {
            self.send(io, &NAMED_VALUE_FLOAT_DATA { time_boot_ms: self.clock_ms, value, name: NAME_CLEARANCE.into() });
        }
    }

    /// A refused `MISSION_START`: the reason as `STATUSTEXT` (headline, then the numbers) and
    /// at once in a `HEARTBEAT` (refusal code in `custom_mode` bits 16..23), before the
    /// `COMMAND_ACK`.
    pub(super) fn refused(&mut self, e: &StartError, io: &mut impl Io) {
        self.refusal = e.code();
        let (head, detail) = e.lines();
        for line in core::iter::once(head).chain(detail) {
            self.send(io, &STATUSTEXT_DATA { severity: MavSeverity::MAV_SEVERITY_ERROR, text: line.bytes().into() });
        }
        self.send_status(io);
    }

    /// The parameter list's next frames, while the link has more than [`super::PARAM_LIST_HEADROOM`]
    /// bytes free.
    pub(super) fn send_param_list(&mut self, io: &mut impl Io) {
        while let Some(k) = self.param_list_next {
            let Some(p) = Param::from_index(usize::from(k)) else {
                self.param_list_next = None;
                return;
            };
            if io.tx_room() <= super::PARAM_LIST_HEADROOM {
                return;
            }
            self.send_param(io, p);
            self.param_list_next = k.checked_add(1);
        }
    }

    pub(super) fn send_param(&mut self, io: &mut impl Io, p: Param) {
        let msg = PARAM_VALUE_DATA {
            param_value: self.params.get(p),
            param_count: params::COUNT as u16,
            param_index: p as u16,
            param_id: p.info().name.into(),
            param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
        };
        self.send(io, &msg);
    }
}
