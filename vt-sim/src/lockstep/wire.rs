//! The MAVLink 2 wire between the host and a companion: frame encoding, the messages the
//! companion sends decoded into [`Rx`], and the frames of one lockstep tick.

use super::{AUTOPILOT_COMPONENT_ID, LOAD_COMPONENT_ID, SYSID_BASE};
use mavlink::dialects::common::{
    MavAutopilot, MavModeFlag, MavState, MavType, COMMAND_ACK_DATA, DEBUG_VECT_DATA, HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA,
    MISSION_ACK_DATA, MISSION_COUNT_DATA, MISSION_ITEM_INT_DATA, MISSION_REQUEST_INT_DATA, NAMED_VALUE_FLOAT_DATA, NAMED_VALUE_INT_DATA, PARAM_VALUE_DATA, POSITION_TARGET_LOCAL_NED_DATA,
    SET_ATTITUDE_TARGET_DATA, STATUSTEXT_DATA, SYSTEM_TIME_DATA, SYS_STATUS_DATA,
};
use mavlink::{MAVLinkV2MessageRaw, MavHeader, MavlinkVersion, MessageData};
use nalgebra::Vector3;
use vt_companion::companion::{NAME_AGES, NAME_CABLE_FORCE, NAME_CLEARANCE, NAME_CYCLES, NAME_REPLAN, NAME_TUBES};
use vt_companion::COMPANION_COMPONENT_ID;

type V3f = Vector3<f32>;

/// Frames sent by the host, with one sequence counter per sending component.
#[derive(Debug, Default)]
pub struct Encoder {
    seq: u8,
}

impl Encoder {
    /// One MAVLink 2 frame from (`system`, `component`).
    pub fn frame<D: MessageData>(&mut self, system: u8, component: u8, data: &D) -> Vec<u8> {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message_data(MavHeader { system_id: u32::from(system), component_id: component, sequence: self.seq }, data);
        self.seq = self.seq.wrapping_add(1);
        raw.raw_bytes().to_vec()
    }
}

/// `LOCAL_POSITION_NED` for an ENU position and velocity.
pub fn local_position(time_ms: u32, pos_enu: &V3f, vel_enu: &V3f) -> LOCAL_POSITION_NED_DATA {
    let [x, y, z] = vt_companion::frames::ned_from_enu(pos_enu);
    let [vx, vy, vz] = vt_companion::frames::ned_from_enu(vel_enu);
    LOCAL_POSITION_NED_DATA { time_boot_ms: time_ms, x, y, z, vx, vy, vz }
}

/// What the companion sent, decoded.
#[derive(Debug, Clone, PartialEq)]
pub enum Rx {
    /// `SET_ATTITUDE_TARGET`.
    Setpoint {
        /// `time_boot_ms`.
        time_ms: u32,
        /// Quaternion FRD -> NED, `[w, x, y, z]`.
        q: [f32; 4],
        /// Collective, `[0, 1]`.
        thrust: f32,
    },
    /// `POSITION_TARGET_LOCAL_NED`: the high-level velocity command (NED, m/s).
    VelocityTarget {
        /// `time_boot_ms`.
        time_ms: u32,
        /// Velocity, NED.
        v_ned: [f32; 3],
    },
    /// `DEBUG_VECT` `FHAT_NED`: the CFO's cable-force estimate (NED, N).
    CableForce([f32; 3]),
    /// `DEBUG_VECT` `CYCLES`: last high-level, last low-level, worst low-level step (cycles).
    Cycles([f32; 3]),
    /// `HEARTBEAT`: `custom_mode` (mode | hold reasons << 8).
    Heartbeat(u32),
    /// `SYS_STATUS` error counters: comm (checksum + framing), unknown ids, bad values,
    /// overruns, discarded bytes.
    Status([u16; 5]),
    /// `PARAM_VALUE`.
    ParamValue(String, f32),
    /// `MISSION_REQUEST_INT`.
    MissionRequest(u16),
    /// `MISSION_ACK` (`MAV_MISSION_RESULT` value).
    MissionAck(u32),
    /// `COMMAND_ACK` (command, `MAV_RESULT` value).
    CommandAck(u32, u32),
    /// `NAMED_VALUE_INT`.
    NamedInt(String, i32),
    /// `DEBUG_VECT` `AGES`: own, load and oldest team data age, ms (-1: never).
    Ages([f32; 3]),
    /// `NAMED_VALUE_FLOAT` `CLEAR`: the own centre's distance to the tube boundary, m.
    Clearance(f32),
    /// `STATUSTEXT`: severity (`MAV_SEVERITY`) and text.
    StatusText(u32, String),
    /// `MISSION_COUNT` (issue 28: the start of a planner's tube offer, pushed to the team).
    MissionCount(u16),
    /// `MISSION_ITEM_INT` (an item of a pushed offer).
    MissionItem(Box<MISSION_ITEM_INT_DATA>),
    /// `DEBUG_VECT` `REPLAN`: re-plans started, re-plans that gave a tube, longest re-plan in
    /// board cycles (since the map was configured).
    Replan([f32; 3]),
    /// `DEBUG_VECT` `TUBES`: switches to an offered tube, offers declined, 1 while this planner
    /// holds the team for want of a route.
    Tubes([f32; 3]),
    /// Anything else (message id).
    Other(u32),
}

/// Pushes received link bytes through `framer` and queues every frame [`decode`] knows, in
/// order (the receive path every port shares: the twin, UDP, QEMU).
pub fn decode_into(framer: &mut vt_companion::Framer, bytes: &[u8], pending: &mut std::collections::VecDeque<Rx>) {
    for &b in bytes {
        framer.push(b);
        while let Some(f) = framer.next_frame() {
            if let Some(rx) = decode(f.message_id, f.payload) {
                pending.push_back(rx);
            }
        }
    }
}

/// The companion message `id` with `payload`, decoded (`None`: malformed).
pub fn decode(id: u32, payload: &[u8]) -> Option<Rx> {
    let v2 = MavlinkVersion::V2;
    Some(match id {
        SET_ATTITUDE_TARGET_DATA::ID => {
            let d = SET_ATTITUDE_TARGET_DATA::deser(v2, payload).ok()?;
            Rx::Setpoint { time_ms: d.time_boot_ms, q: d.q, thrust: d.thrust }
        }
        POSITION_TARGET_LOCAL_NED_DATA::ID => {
            let d = POSITION_TARGET_LOCAL_NED_DATA::deser(v2, payload).ok()?;
            Rx::VelocityTarget { time_ms: d.time_boot_ms, v_ned: [d.vx, d.vy, d.vz] }
        }
        DEBUG_VECT_DATA::ID => {
            let d = DEBUG_VECT_DATA::deser(v2, payload).ok()?;
            match d.name.to_str().unwrap_or("") {
                n if n == NAME_CABLE_FORCE => Rx::CableForce([d.x, d.y, d.z]),
                n if n == NAME_CYCLES => Rx::Cycles([d.x, d.y, d.z]),
                n if n == NAME_AGES => Rx::Ages([d.x, d.y, d.z]),
                n if n == NAME_REPLAN => Rx::Replan([d.x, d.y, d.z]),
                n if n == NAME_TUBES => Rx::Tubes([d.x, d.y, d.z]),
                _ => Rx::Other(id),
            }
        }
        HEARTBEAT_DATA::ID => Rx::Heartbeat(HEARTBEAT_DATA::deser(v2, payload).ok()?.custom_mode),
        SYS_STATUS_DATA::ID => {
            let d = SYS_STATUS_DATA::deser(v2, payload).ok()?;
            Rx::Status([d.errors_comm, d.errors_count1, d.errors_count2, d.errors_count3, d.errors_count4])
        }
        PARAM_VALUE_DATA::ID => {
            let d = PARAM_VALUE_DATA::deser(v2, payload).ok()?;
            Rx::ParamValue(d.param_id.to_str().unwrap_or("").to_string(), d.param_value)
        }
        MISSION_REQUEST_INT_DATA::ID => Rx::MissionRequest(MISSION_REQUEST_INT_DATA::deser(v2, payload).ok()?.seq),
        MISSION_COUNT_DATA::ID => Rx::MissionCount(MISSION_COUNT_DATA::deser(v2, payload).ok()?.count),
        MISSION_ITEM_INT_DATA::ID => Rx::MissionItem(Box::new(MISSION_ITEM_INT_DATA::deser(v2, payload).ok()?)),
        MISSION_ACK_DATA::ID => Rx::MissionAck(MISSION_ACK_DATA::deser(v2, payload).ok()?.mavtype as u32),
        COMMAND_ACK_DATA::ID => {
            let d = COMMAND_ACK_DATA::deser(v2, payload).ok()?;
            Rx::CommandAck(d.command as u32, d.result as u32)
        }
        NAMED_VALUE_INT_DATA::ID => {
            let d = NAMED_VALUE_INT_DATA::deser(v2, payload).ok()?;
            Rx::NamedInt(d.name.to_str().unwrap_or("").to_string(), d.value)
        }
        NAMED_VALUE_FLOAT_DATA::ID => {
            let d = NAMED_VALUE_FLOAT_DATA::deser(v2, payload).ok()?;
            match d.name.to_str().unwrap_or("") {
                n if n == NAME_CLEARANCE => Rx::Clearance(d.value),
                _ => Rx::Other(id),
            }
        }
        STATUSTEXT_DATA::ID => {
            let d = STATUSTEXT_DATA::deser(v2, payload).ok()?;
            let text: Vec<u8> = d.text.iter().copied().take_while(|&b| b != 0).collect();
            Rx::StatusText(d.severity as u32, String::from_utf8_lossy(&text).into_owned())
        }
        other => Rx::Other(other),
    })
}

/// The frames of one lockstep tick for one UAV: load and neighbours (when the high level is
/// due), then the own state that triggers the steps.
pub struct TickFrames<'a> {
    /// Simulated time, ms.
    pub time_ms: u32,
    /// Own system id.
    pub system_id: u8,
    /// Load state (position, velocity), ENU, when the high level is due.
    pub load: Option<(V3f, V3f)>,
    /// Neighbours' positions and velocities by UAV index (`None`: not delivered), when the high
    /// level is due.
    pub neighbours: &'a [Option<crate::mission::Report>],
    /// Own position and velocity, ENU.
    pub own: (V3f, V3f),
    /// Sample times of the own and the load state, ms (`time_boot_ms`; older than `time_ms`
    /// by the sensor latency).
    pub sample_ms: (u32, u32),
    /// This UAV's index (skipped among the neighbours).
    pub id: usize,
}

impl TickFrames<'_> {
    /// Encodes the tick.
    pub fn encode(&self, autopilot: &mut Encoder, tracker: &mut Encoder, network: &mut Encoder) -> Vec<u8> {
        self.encode_with(autopilot, tracker, network, &[])
    }

    /// Encodes the tick with `relayed` (frames the team network relays this period: range scans,
    /// a tube offer) after the load's and the neighbours' states, before the own state.
    pub fn encode_with(&self, autopilot: &mut Encoder, tracker: &mut Encoder, network: &mut Encoder, relayed: &[u8]) -> Vec<u8> {
        let (own_sample_ms, _) = self.sample_ms;
        let mut out = Vec::with_capacity(64 * (3 + self.neighbours.len()));
        if own_sample_ms != self.time_ms {
            // Lockstep clock: the autopilot's SYSTEM_TIME opens the period at "now" when its own
            // sample is older (docs/protocol.md).
            out.extend(autopilot.frame(self.system_id, AUTOPILOT_COMPONENT_ID, &self.system_time()));
        }
        self.encode_team(tracker, network, &mut out);
        out.extend_from_slice(relayed);
        out.extend(autopilot.frame(self.system_id, AUTOPILOT_COMPONENT_ID, &local_position(own_sample_ms, &self.own.0, &self.own.1)));
        out
    }

    /// Encodes the tick of a UAV whose own position feed stalls (`own_feed_stall`): the
    /// autopilot's `SYSTEM_TIME` at `time_ms` opens the period, the load and the neighbours
    /// follow as usual, and a second `SYSTEM_TIME` at the same time closes it instead of the own
    /// state (the lockstep clock, docs/protocol.md).
    pub fn encode_stalled(&self, autopilot: &mut Encoder, tracker: &mut Encoder, network: &mut Encoder) -> Vec<u8> {
        self.encode_stalled_with(autopilot, tracker, network, &[])
    }

    /// [`Self::encode_stalled`] with `relayed` as in [`Self::encode_with`].
    pub fn encode_stalled_with(&self, autopilot: &mut Encoder, tracker: &mut Encoder, network: &mut Encoder, relayed: &[u8]) -> Vec<u8> {
        let mut out = Vec::with_capacity(64 * (3 + self.neighbours.len()));
        out.extend(autopilot.frame(self.system_id, AUTOPILOT_COMPONENT_ID, &self.system_time()));
        self.encode_team(tracker, network, &mut out);
        out.extend_from_slice(relayed);
        out.extend(autopilot.frame(self.system_id, AUTOPILOT_COMPONENT_ID, &self.system_time()));
        out
    }

    /// The autopilot's `SYSTEM_TIME` at the tick's time (the lockstep clock).
    fn system_time(&self) -> SYSTEM_TIME_DATA {
        SYSTEM_TIME_DATA { time_unix_usec: 0, time_boot_ms: self.time_ms }
    }

    /// The load's and the neighbours' states, appended to `out`.
    fn encode_team(&self, tracker: &mut Encoder, network: &mut Encoder, out: &mut Vec<u8>) {
        let (_, load_sample_ms) = self.sample_ms;
        if let Some((p, v)) = &self.load {
            out.extend(tracker.frame(self.system_id, LOAD_COMPONENT_ID, &local_position(load_sample_ms, p, v)));
            for (j, nb) in self.neighbours.iter().enumerate() {
                if let (Some((p, v)), true) = (nb, j != self.id) {
                    let sys = SYSID_BASE + j as u8;
                    out.extend(network.frame(sys, AUTOPILOT_COMPONENT_ID, &local_position(self.time_ms, p, v)));
                }
            }
        }
    }
}

/// UAV `j`'s companion `HEARTBEAT` with `custom_mode` as the team network relays it to the
/// others (docs/protocol.md, "Team failsafe").
pub fn relayed_heartbeat(network: &mut Encoder, j: usize, custom_mode: u32) -> Vec<u8> {
    let d = HEARTBEAT_DATA {
        custom_mode,
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    };
    network.frame(SYSID_BASE.saturating_add(j.min(255) as u8), COMPANION_COMPONENT_ID, &d)
}

/// Per-UAV encoders (autopilot, load tracker, network relay) and the ground station's.
#[derive(Debug, Default)]
pub struct Encoders {
    /// The UAV's autopilot.
    pub autopilot: Encoder,
    /// Its load tracker.
    pub tracker: Encoder,
    /// The team network relay.
    pub network: Encoder,
    /// The ground station.
    pub gcs: Encoder,
}
