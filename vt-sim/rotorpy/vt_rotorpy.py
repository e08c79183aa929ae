#!/usr/bin/env python3
"""RotorPy as the plant of a cooperative-transport flight (issue 26; docs/plant.md, "RotorPy").

N RotorPy `Multirotor`s (Folk et al. 2023, PyPI `rotorpy`: its rotor, motor and aerodynamic
model and its `cmd_ctatt` attitude controller) carry a point-mass load on tension-only elastic
cables, in the scenario's wind, flown by unchanged `vt-companion` processes over the lockstep
MAVLink protocol `host-sim serve` speaks (docs/protocol.md). `host-sim sitl --plant rotorpy`
writes the configuration (config.json: the airframe host-sim sizes, the take-off state, the
cables, the wind, the tube's samples for the stop), starts this program and the companions,
uploads and starts them with its ground station, and scores the trajectory this program writes
(host-sim's trajectory.csv columns) with `host-sim score`.

Control of this program (stdin/stdout, one line each):
  -> `PORTS p0 p1 ...`        the UDP ports UAV 0..n-1 listen on (127.0.0.1)
  <- `FLY`                     the companions are configured: fly the pre-flight
  -> `START`                   pre-flight flown, take-off tick sent: send MISSION_START now
  <- `GO` | `ABORT`            the ground station's start was accepted (or not)
  -> `DONE rows wall_s`        trajectory written; exit 0 (any failure: a message, exit 1)
"""

import csv
import json
import math
import socket
import sys
import time

import numpy as np
from pymavlink.dialects.v20 import common as mavlink
from rotorpy.vehicles.multirotor import Multirotor

AUTOPILOT_COMPONENT = 1
COMPANION_COMPONENT = 191
GCS_SYSTEM, GCS_COMPONENT = 255, 190
REPLY_TIMEOUT_S = 30.0
AIR_DENSITY = 1.225  # kg/m^3, as host-sim's drag (disturbance.rs)
G = 9.81  # m/s^2, RotorPy's gravity (Multirotor.g)
SQRT_HALF = math.sqrt(0.5)
# RotorPy Hummingbird (hummingbird_params.py) figures the sizing scales from.
HB_ARM_M = 0.17
HB_KZ_OVER_KD = 2.32e-4 / 1.19e-4
HB_KH = 3.39e-3
HB_KP_ATT, HB_KD_ATT = 544.0, 46.64


def fail(msg):
    print(f"vt_rotorpy: {msg}", file=sys.stderr, flush=True)
    sys.exit(1)


def quad_params(a):
    """RotorPy parameters of the airframe host-sim sized (quadrotor/params.rs `QuadParams::sized`).

    Mass, inertia, arm, rotor thrust coefficient, maximum rotor speed, yaw-moment ratio, rotor
    drag, parasitic drag and motor time constant are host-sim's; the induced-inflow and
    translational-lift coefficients, which host-sim's model lacks, are the Hummingbird's scaled
    (k_z with k_d, k_h with the rotor disc area ~ arm^2); the attitude gains are the Hummingbird's
    (angular-acceleration units, so they do not depend on the size)."""
    d = a["arm_m"] * SQRT_HALF
    k_eta = a["k_eta"]
    return {
        "mass": a["mass_kg"],
        "Ixx": a["inertia_kgm2"][0], "Iyy": a["inertia_kgm2"][1], "Izz": a["inertia_kgm2"][2],
        "Ixy": 0.0, "Iyz": 0.0, "Ixz": 0.0,
        "num_rotors": 4,
        "rotor_radius": a["arm_m"] * 0.5,
        "rotor_pos": {
            "r1": np.array([d, d, 0.0]), "r2": np.array([d, -d, 0.0]),
            "r3": np.array([-d, -d, 0.0]), "r4": np.array([-d, d, 0.0]),
        },
        "rotor_directions": np.array([1, -1, 1, -1]),
        "rI": np.zeros(3),
        "c_Dx": a["body_drag"][0], "c_Dy": a["body_drag"][1], "c_Dz": a["body_drag"][2],
        "k_eta": k_eta,
        "k_m": a["yaw_moment_m"] * k_eta,
        "k_d": a["rotor_drag"],
        "k_z": a["rotor_drag"] * HB_KZ_OVER_KD,
        "k_h": HB_KH * (a["arm_m"] / HB_ARM_M) ** 2,
        "k_flap": 0.0,
        "tau_m": a["motor_tau_s"],
        "rotor_speed_min": math.sqrt(a["rotor_thrust_min_n"] / k_eta),
        "rotor_speed_max": math.sqrt(a["rotor_thrust_max_n"] / k_eta),
        "motor_noise_std": 0.0,
        "k_w": 1.0, "k_v": 10.0,
        "kp_att": HB_KP_ATT, "kd_att": HB_KD_ATT,
    }


class CarryingMultirotor(Multirotor):
    """RotorPy's multirotor with its cable: a tension-only spring-damper from the hook
    (`attach`, body frame, below the centre of mass) to the load, whose state is held over one
    plant step. The force enters RotorPy's dynamics at the hook (force and moment) inside the
    derivative, so the integrator sees the cable stiffen as the UAV moves."""

    def __init__(self, params, state, attach, cable, dt):
        # RotorPy's own integrator (scipy RK45, adaptive, its default tolerances), trying the
        # whole plant step first rather than guessing an initial step on every call.
        super().__init__(params, state, control_abstraction="cmd_ctatt", aero=True, enable_ground=False,
                         integrator_kwargs={"method": "RK45", "first_step": dt})
        self.attach = np.asarray(attach, dtype=float)
        self.rest_m, self.k, self.c = cable
        self.broken = False
        self.load_x = np.zeros(3)
        self.load_v = np.zeros(3)

    def hook(self, x, v, q, w):
        r = rotation(q)
        return x + r @ self.attach, v + r @ cross(w, self.attach), r

    def tension(self, p, v):
        """Tension (N) and unit vector load -> hook of the cable with its hook at `p`, `v`."""
        if self.broken:
            return 0.0, np.zeros(3)
        d = p - self.load_x
        length = float(np.linalg.norm(d))
        if length <= self.rest_m or length < 1e-6:
            return 0.0, np.zeros(3)
        u = d / length
        t = self.k * (length - self.rest_m) + self.c * float(u @ (v - self.load_v))
        return max(t, 0.0), u

    def _s_dot_fn(self, t, s, cmd_rotor_speeds):
        s_dot = super()._s_dot_fn(t, s, cmd_rotor_speeds)
        p, v, r = self.hook(s[0:3], s[3:6], s[6:10], s[10:13])
        tension, u = self.tension(p, v)
        if tension > 0.0:
            f = -tension * u
            s_dot[3:6] += f / self.mass
            s_dot[10:13] += self.inv_inertia @ cross(self.attach, r.T @ f)
        return s_dot


def rotation(q):
    """Rotation matrix of a quaternion `[x, y, z, w]` (normalised here, as scipy's `Rotation`
    does; written out because the derivative calls it on every evaluation)."""
    x, y, z, w = (float(c) for c in q)
    k = 2.0 / (x * x + y * y + z * z + w * w)
    return np.array([
        [1.0 - k * (y * y + z * z), k * (x * y - z * w), k * (x * z + y * w)],
        [k * (x * y + z * w), 1.0 - k * (x * x + z * z), k * (y * z - x * w)],
        [k * (x * z - y * w), k * (y * z + x * w), 1.0 - k * (x * x + y * y)],
    ])


def cross(a, b):
    """`a x b` of two 3-vectors (numpy's `cross` costs microseconds of argument handling)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def q_enu_xyzw(q_ned):
    """RotorPy attitude `[x, y, z, w]` (FLU body to ENU) of a MAVLink `q` (`[w, x, y, z]`, FRD
    body to NED): the inverse of the companion's `frames::ned_frd_quaternion`."""
    a, b, c, d = q_ned
    w, z = (a + d) * SQRT_HALF, (a - d) * SQRT_HALF
    x, y = (b + c) * SQRT_HALF, (b - c) * SQRT_HALF
    return np.array([x, y, z, w])


def ned(v):
    return float(v[1]), float(v[0]), -float(v[2])


class Link:
    """One UAV's UDP port: what its autopilot, load tracker, team network and (for the
    pre-flight round trips) the ground station send, and the companion's replies."""

    def __init__(self, system_id):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(REPLY_TIMEOUT_S)
        self.port = self.sock.getsockname()[1]
        self.peer = None
        self.system_id = system_id
        self.tx = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=AUTOPILOT_COMPONENT)
        self.rx = mavlink.MAVLink(None)
        self.rx.robust_parsing = True
        self.out = bytearray()
        self.custom_mode = 0
        self.statustext = []

    def queue(self, msg, system, component):
        self.tx.srcSystem, self.tx.srcComponent = system, component
        self.out += msg.pack(self.tx)

    def flush(self):
        if self.out:
            self.sock.sendto(bytes(self.out), self.peer)
            self.out = bytearray()

    def wait_peer(self):
        """The companion's address, from its first datagram (its 1 Hz idle heartbeat)."""
        while self.peer is None:
            data, addr = self.sock.recvfrom(65536)
            self.peer = addr
            self.parse(data)

    def parse(self, data):
        msgs = self.rx.parse_buffer(data) or []
        for m in msgs:
            if m.get_type() == "HEARTBEAT":
                self.custom_mode = m.custom_mode
            elif m.get_type() == "STATUSTEXT":
                self.statustext.append(m.text)
        return msgs

    def wait_for(self, predicate, what):
        deadline = time.monotonic() + REPLY_TIMEOUT_S
        while time.monotonic() < deadline:
            try:
                data, _ = self.sock.recvfrom(65536)
            except socket.timeout:
                break
            for m in self.parse(data):
                r = predicate(m)
                if r is not None:
                    return r
        fail(f"UAV system {self.system_id}: no {what} within {REPLY_TIMEOUT_S:.0f} s")


def team_mode(custom_mode):
    """The team mode a companion's heartbeat announces (host-sim `team_mode_of`): 3 Hold, 4 team
    hold, else transport (2)."""
    m = custom_mode & 0xFF
    return m if m in (3, 4) else 2


class Wind:
    """The scenario's wind (host-sim `disturbance::Wind`): mean plus horizontal gusts, one
    Ornstein-Uhlenbeck process per axis, discretised exactly. Its own random stream: the gusts
    are statistically, not bit for bit, host-sim's."""

    def __init__(self, w):
        self.mean = np.array(w["mean_mps"], dtype=float)
        self.std, self.tau = w["gust_std_mps"], max(w["gust_tau_s"], 1e-6)
        self.rng = np.random.default_rng(w["seed"])
        self.gust = self.rng.normal(size=2) * self.std

    def step(self, dt):
        if self.std > 0.0:
            e = math.exp(-dt / self.tau)
            self.gust = self.gust * e + self.std * math.sqrt(1.0 - e * e) * self.rng.normal(size=2)
        return self.mean + np.array([self.gust[0], self.gust[1], 0.0])


# Height of the scenario's wind, m: 20 ft, MIL-F-8785C's W20 (host-sim `disturbance::WIND_REFERENCE_HEIGHT_M`).
WIND_REFERENCE_HEIGHT_M = 20.0 * 0.3048


def shear_factor(height_m, roughness_m):
    """The share of the scenario's wind blowing at `height_m` (host-sim `disturbance::shear_factor`):
    MIL-F-8785C's log law below 20 ft, 0 at and below the roughness length, 1 above; 1 everywhere
    with no roughness."""
    if not (0.0 < roughness_m < WIND_REFERENCE_HEIGHT_M) or height_m >= WIND_REFERENCE_HEIGHT_M:
        return 1.0
    if not height_m > roughness_m:
        return 0.0
    return min(1.0, max(0.0, math.log(height_m / roughness_m) / math.log(WIND_REFERENCE_HEIGHT_M / roughness_m)))


class Plant:
    def __init__(self, cfg):
        self.cfg = cfg
        a = cfg["airframe"]
        params = quad_params(a)
        self.t_max = a["thrust_max_n"]
        c = cfg["cables"]
        # Facing the heading the companions hold (host-sim's plant starts so too).
        h = a["heading_enu_rad"]
        self.level = np.array([0.0, 0.0, math.sin(h / 2.0), math.cos(h / 2.0)])
        self.uavs, self.states = [], []
        for i, x in enumerate(cfg["start"]["uav_pos_m"]):
            state = {
                "x": np.array(x, dtype=float), "v": np.zeros(3), "q": self.level.copy(),
                "w": np.zeros(3), "wind": np.zeros(3), "rotor_speeds": np.zeros(4),
            }
            u = CarryingMultirotor(params, state, a["attach_body_m"], (c["lengths_m"][i], c["stiffness_n_per_m"][i], c["damping_ns_per_m"]),
                                   1.0 / cfg["rates"]["plant_hz"])
            self.uavs.append(u)
            self.states.append(state)
        self.load_x = np.array(cfg["start"]["load_pos_m"], dtype=float)
        self.load_v = np.zeros(3)
        self.load_m = cfg["load"]["mass_kg"]
        self.load_area = cfg["load"]["drag_area_m2"]
        self.breaking = c["breaking_n"]
        self.wind = Wind(cfg["wind"])
        self.roughness = cfg["wind"].get("surface_roughness_m", 0.0)
        self.wind_now = np.zeros(3)
        self.tensions = np.zeros(len(self.uavs))
        # Hover: every rotor carries a quarter of the UAV's weight and of its cable's pull.
        self.update_tensions()
        for u, s, t in zip(self.uavs, self.states, self.tensions):
            s["rotor_speeds"][:] = math.sqrt((u.mass * G + t) / 4.0 / u.k_eta)
        self.commands = [{"cmd_thrust": u.mass * G + t, "cmd_q": self.level.copy()} for u, t in zip(self.uavs, self.tensions)]

    def update_tensions(self):
        force = np.zeros(3)
        for i, (u, s) in enumerate(zip(self.uavs, self.states)):
            u.load_x, u.load_v = self.load_x, self.load_v
            p, v, _ = u.hook(s["x"], s["v"], s["q"], s["w"])
            t, dirn = u.tension(p, v)
            self.tensions[i] = t
            force += t * dirn
        return force

    def set_command(self, i, q_ned, thrust):
        self.commands[i] = {"cmd_thrust": float(thrust) * self.t_max, "cmd_q": q_enu_xyzw(q_ned)}

    def step(self, dt):
        self.wind_now = self.wind.step(dt)
        for u, s, cmd in zip(self.uavs, self.states, self.commands):
            u.load_x, u.load_v = self.load_x, self.load_v
            s["wind"] = self.wind_now * shear_factor(float(s["x"][2]), self.roughness)
            new = u.step(s, cmd, dt)
            s.update(new)
        force = self.update_tensions()
        for u, t in zip(self.uavs, self.tensions):
            if t > self.breaking:
                u.broken = True
        rel = self.wind_now * shear_factor(float(self.load_x[2]), self.roughness) - self.load_v
        drag = rel * (0.5 * AIR_DENSITY * self.load_area * float(np.linalg.norm(rel)))
        acc = (force + drag) / self.load_m + np.array([0.0, 0.0, -G])
        # Semi-implicit Euler for the load (velocity first), over the UAVs' new states.
        self.load_v = self.load_v + acc * dt
        self.load_x = self.load_x + self.load_v * dt

    def thrust(self, i):
        u, s = self.uavs[i], self.states[i]
        return float(u.k_eta * np.sum(s["rotor_speeds"] ** 2))

    def finite(self):
        return all(np.all(np.isfinite(s["x"])) and np.all(np.isfinite(s["v"])) for s in self.states) and np.all(np.isfinite(self.load_x))


class Flight:
    def __init__(self, cfg):
        self.cfg = cfg
        self.n = len(cfg["system_ids"])
        self.ids = cfg["system_ids"]
        self.load_comp = cfg["load_component"]
        r = cfg["rates"]
        self.plant_hz, self.ll_hz, self.hl_hz = r["plant_hz"], r["low_level_hz"], r["high_level_hz"]
        self.substeps = self.plant_hz // self.ll_hz
        self.hl_every = self.ll_hz // self.hl_hz
        self.plant = Plant(cfg)
        self.links = [Link(i) for i in self.ids]
        self.relayed = [[2] * self.n for _ in range(self.n)]
        samples = np.array(cfg["tube"]["samples"], dtype=float)
        self.tube_xy, self.tube_s = samples[:, 0:2], samples[:, 2]
        self.end_s = cfg["tube"]["end_s_m"]
        # Last sample (what the high level reads: the previous period's, as host-sim's sensors).
        self.last = None

    def sample(self, time_ms):
        p = self.plant
        return {
            "ms": time_ms,
            "uav": [(s["x"].copy(), s["v"].copy()) for s in p.states],
            "load": (p.load_x.copy(), p.load_v.copy()),
        }

    def tick(self, now, high_level):
        """Queues the period's frames for every UAV (docs/protocol.md, lockstep) and sends them."""
        held = self.last if self.last is not None else now
        for i, link in enumerate(self.links):
            sys_i = self.ids[i]
            if high_level:
                for j in range(self.n):
                    mode = team_mode(self.links[j].custom_mode)
                    if j != i and mode != self.relayed[i][j]:
                        self.relayed[i][j] = mode
                        hb = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID,
                                                               mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode, mavlink.MAV_STATE_ACTIVE, 3)
                        link.queue(hb, self.ids[j], COMPANION_COMPONENT)
                lx, lv = held["load"]
                link.queue(mavlink.MAVLink_local_position_ned_message(held["ms"], *ned(lx), *ned(lv)), sys_i, self.load_comp)
                for j, (x, v) in enumerate(held["uav"]):
                    if j != i:
                        # The member's velocity too: the dashpots of a team near its capacity
                        # read it (docs/design.md).
                        link.queue(mavlink.MAVLink_local_position_ned_message(now["ms"], *ned(x), *ned(v)), self.ids[j], AUTOPILOT_COMPONENT)
            x, v = now["uav"][i]
            link.queue(mavlink.MAVLink_local_position_ned_message(now["ms"], *ned(x), *ned(v)), sys_i, AUTOPILOT_COMPONENT)
            link.flush()

    def time_ms(self, period):
        return int(round(period * 1000.0 / self.ll_hz))

    def preflight(self, periods):
        for k in range(periods):
            now = self.sample(self.time_ms(k))
            self.tick(now, k % self.hl_every == 0)
            self.last = now
            for i, link in enumerate(self.links):
                req = mavlink.MAVLink_param_request_read_message(self.ids[i], COMPANION_COMPONENT, b"VT_ID", -1)
                link.queue(req, GCS_SYSTEM, GCS_COMPONENT)
                link.flush()
                link.wait_for(lambda m: True if m.get_type() == "PARAM_VALUE" else None, "PARAM_VALUE after a pre-flight period")

    def collect(self, now_ms):
        for i, link in enumerate(self.links):
            def setpoint(m):
                if m.get_type() == "SET_ATTITUDE_TARGET" and m.time_boot_ms == now_ms:
                    return m
                return None
            m = link.wait_for(setpoint, f"SET_ATTITUDE_TARGET at {now_ms} ms")
            self.plant.set_command(i, m.q, m.thrust)

    def fly(self, writer, boot_periods):
        cfg, p = self.cfg, self.plant
        dt = 1.0 / self.plant_hz
        ll_dt = 1.0 / self.ll_hz
        limit = int(round(cfg["time_limit_s"] * self.ll_hz))
        post = int(round(cfg["post_arrival_s"] * self.ll_hz))
        arrival = None
        rows = 0
        for k in range(limit):
            clock = boot_periods + k
            now = self.sample(self.time_ms(clock))
            high_level = clock % self.hl_every == 0
            if high_level:
                d2 = np.sum((self.tube_xy - p.load_x[0:2]) ** 2, axis=1)
                if arrival is None and self.tube_s[int(np.argmin(d2))] >= self.end_s:
                    arrival = k
            if arrival is not None and k - arrival >= post:
                break
            self.tick(now, high_level)
            self.last = now
            self.collect(now["ms"])
            writer.writerow(self.row(k * ll_dt))
            rows += 1
            for _ in range(self.substeps):
                p.step(dt)
            if not p.finite():
                writer.writerow(self.row((k + 1) * ll_dt))
                rows += 1
                break
        return rows

    def row(self, t):
        p = self.plant
        out = [repr(t)]
        for i, s in enumerate(p.states):
            out += [repr(float(c)) for c in s["x"]] + [repr(float(c)) for c in s["v"]]
            out += [repr(p.thrust(i)), repr(float(p.tensions[i]))]
        out += [repr(float(c)) for c in p.load_x] + [repr(float(c)) for c in p.load_v]
        return out


def header(n):
    cols = ["time_s"]
    for i in range(n):
        cols += [f"uav{i}_{c}" for c in ("x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "thrust_n", "tension_n")]
    return cols + ["load_x_m", "load_y_m", "load_z_m", "load_vx_mps", "load_vy_mps", "load_vz_mps"]


def expect(line):
    got = sys.stdin.readline().strip()
    if got != line:
        fail(f"expected `{line}` from host-sim, got `{got}`")
    return got


def main():
    if len(sys.argv) != 2:
        fail("usage: vt_rotorpy.py CONFIG.json")
    with open(sys.argv[1], encoding="utf-8") as f:
        cfg = json.load(f)
    flight = Flight(cfg)
    print("PORTS " + " ".join(str(link.port) for link in flight.links), flush=True)
    expect("FLY")
    for link in flight.links:
        link.wait_peer()
    wall = time.monotonic()
    boot = cfg["preflight_periods"]
    flight.preflight(boot)
    # The take-off tick, as host-sim's start: every view complete, high level due.
    now = flight.sample(flight.time_ms(boot))
    flight.tick(now, True)
    flight.last = now
    print("START", flush=True)
    if sys.stdin.readline().strip() != "GO":
        fail("the ground station's start was refused")
    for link in flight.links:
        link.wait_for(lambda m: True if m.get_type() == "COMMAND_ACK" and m.command == mavlink.MAV_CMD_MISSION_START else None, "COMMAND_ACK of MISSION_START")
    with open(cfg["trajectory"], "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(header(flight.n))
        rows = flight.fly(writer, boot)
    print(f"DONE {rows} {time.monotonic() - wall:.3f}", flush=True)


if __name__ == "__main__":
    main()
