//! The companion on the wall clock: bytes from the link into [`Companion::on_bytes`], the two
//! control steps at `VT_HL_HZ` and `VT_LL_HZ` (the firmware's Tickers; high level first when
//! both are due), frames out. With `VT_LOCKSTEP = 1` the steps run on received own states
//! instead, as in the firmware (a simulator driving the clock).
//!
//! Issue 28: on the wall clock a re-plan's search and an offered tube's build run on a planner
//! thread, as the firmware's perception build runs them in a task below its control loop
//! (`Io::plans_aside`); in lockstep the companion runs them in line.

use crate::link::{Link, READ_CHUNK};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use std::sync::mpsc;
use vt_companion::replanning::{BuildJob, PlanJob, Searched};
use vt_companion::{Companion, Io, Mode, Request};

/// How long one wait for bytes may last when no step is due, ms (the stop flag is polled).
const IDLE_WAIT_MS: u64 = 20;
/// A step more than this many periods late is skipped, not caught up (a stalled process must
/// not fire a burst of stale steps).
const MAX_LATE_PERIODS: u32 = 5;

/// Why the loop ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Exit {
    /// The stop flag (Ctrl-C, SIGTERM): the team was told to hold.
    Stopped,
    /// `MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN` with `param1 = 2`.
    Shutdown,
    /// `MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN` with `param1 = 1`: start over as a fresh companion
    /// (the flight MCU keeps no parameters across a reset either).
    Reboot,
}

/// The board side of the companion on Linux: a monotonic clock and the outgoing frames.
struct WallIo<'a> {
    start: Instant,
    out: &'a mut Vec<Vec<u8>>,
}

impl Io for WallIo<'_> {
    fn now_ms(&self) -> u32 {
        self.start.elapsed().as_millis() as u32
    }

    /// Microseconds (the Linux "cycle"; docs/deploy.md).
    fn cycles(&self) -> u32 {
        self.start.elapsed().as_micros() as u32
    }

    fn send(&mut self, frame: &[u8]) {
        self.out.push(frame.to_vec());
    }

    fn plans_aside(&self) -> bool {
        true
    }
}

/// Work for the planner thread.
enum Job<'t> {
    /// A re-plan's search.
    Plan(PlanJob<'t>),
    /// An offered tube's build (its waypoints inline: boxed).
    Build(Box<BuildJob<'t>>),
}

/// Work back from the planner thread.
enum Done<'t> {
    /// The search, what it found, and how long it took, microseconds.
    Plan(PlanJob<'t>, Box<Searched>, u32),
    /// The build, and whether the tube built.
    Build(Box<BuildJob<'t>>, bool),
}

impl<'t> Job<'t> {
    fn run(self) -> Done<'t> {
        match self {
            Job::Plan(mut j) => {
                let t0 = Instant::now();
                let searched = Box::new(j.run());
                Done::Plan(j, searched, u32::try_from(t0.elapsed().as_micros()).unwrap_or(u32::MAX))
            }
            Job::Build(mut j) => {
                let built = j.run();
                Done::Build(j, built)
            }
        }
    }
}

/// A periodic deadline on the wall clock.
struct Period {
    next: Instant,
    every: Duration,
    hz: u32,
}

impl Period {
    fn new(hz: u32, now: Instant) -> Self {
        let every = Duration::from_secs_f64(1.0 / f64::from(hz.max(1)));
        Self { next: now + every, every, hz }
    }

    /// True (and the deadline moved on) when the step is due at `now`.
    fn due(&mut self, now: Instant) -> bool {
        if now < self.next {
            return false;
        }
        self.next += self.every;
        if now > self.next + self.every * MAX_LATE_PERIODS {
            self.next = now + self.every;
        }
        true
    }
}

/// Runs `companion` on `link` until `stop` is set or a shutdown is requested; `on_mode` hears
/// every mode change.
///
/// # Errors
/// The link failed for good.
pub fn run(companion: &mut Companion<'_>, link: &mut dyn Link, stop: &AtomicBool, on_mode: impl FnMut(Mode, u32)) -> std::io::Result<Exit> {
    std::thread::scope(|s| {
        let (jobs, job_rx) = mpsc::channel::<Job<'_>>();
        let (done_tx, done) = mpsc::channel::<Done<'_>>();
        s.spawn(move || {
            for job in job_rx {
                if done_tx.send(job.run()).is_err() {
                    break;
                }
            }
        });
        // Dropping `jobs` on the way out ends the planner thread; the scope waits for it.
        run_loop(companion, link, stop, on_mode, &jobs, &done)
    })
}

/// What a planner thread brought back goes to the companion; what waits goes to the thread.
fn exchange<'t>(companion: &mut Companion<'t>, jobs: &mpsc::Sender<Job<'t>>, done: &mpsc::Receiver<Done<'t>>) {
    while let Ok(d) = done.try_recv() {
        match d {
            Done::Plan(job, searched, us) => companion.return_plan_job(job, *searched, us),
            Done::Build(job, built) => companion.return_build_job(*job, built),
        }
    }
    if let Some(j) = companion.take_build_job() {
        let _ = jobs.send(Job::Build(Box::new(j)));
    }
    if let Some(j) = companion.take_plan_job() {
        let _ = jobs.send(Job::Plan(j));
    }
}

fn run_loop<'t>(
    companion: &mut Companion<'t>,
    link: &mut dyn Link,
    stop: &AtomicBool,
    mut on_mode: impl FnMut(Mode, u32),
    jobs: &mpsc::Sender<Job<'t>>,
    done: &mpsc::Receiver<Done<'t>>,
) -> std::io::Result<Exit> {
    let start = Instant::now();
    let mut out: Vec<Vec<u8>> = Vec::new();
    let mut buf = vec![0u8; READ_CHUNK];
    let mut mode = companion.mode();
    let mut clocks: Option<(Period, Period)> = None;
    let mut last_beat = start.checked_sub(Duration::from_secs(1)).unwrap_or(start);
    loop {
        if stop.load(Ordering::Relaxed) {
            // Tell the team to hold (a HEARTBEAT in Hold, followed by every fresh neighbour),
            // then go: the autopilot's offboard failsafe takes over (docs/deploy.md).
            companion.operator_hold(true, &mut WallIo { start, out: &mut out });
            flush(link, &mut out)?;
            return Ok(Exit::Stopped);
        }
        let now = Instant::now();
        // The Tickers (re)start when the rates change, and never run in lockstep.
        let rates = (companion.high_level_hz(), companion.low_level_hz());
        if companion.lockstep() {
            clocks = None;
        } else if clocks.as_ref().is_none_or(|(h, l)| (h.hz, l.hz) != rates) {
            clocks = Some((Period::new(rates.0, now), Period::new(rates.1, now)));
        }
        let wait = clocks.as_ref().map_or(Duration::from_millis(IDLE_WAIT_MS), |(h, l)| {
            h.next.min(l.next).saturating_duration_since(now).min(Duration::from_millis(IDLE_WAIT_MS))
        });
        let n = link.recv(&mut buf, wait)?;
        let mut io = WallIo { start, out: &mut out };
        if n > 0 {
            let bytes = buf.get(..n).unwrap_or(&[]);
            let request = if link.datagrams() { companion.on_datagram(bytes, &mut io) } else { companion.on_bytes(bytes, &mut io) };
            let exit = match request {
                Some(Request::Shutdown) => Some(Exit::Shutdown),
                Some(Request::Reboot) => Some(Exit::Reboot),
                None => None,
            };
            if let Some(exit) = exit {
                flush(link, &mut out)?;
                return Ok(exit);
            }
        }
        if let Some((hl, ll)) = clocks.as_mut() {
            let now = Instant::now();
            if hl.due(now) {
                // Work back before the step (its check and switch), new work out after it.
                exchange(companion, jobs, done);
                companion.high_level_step(&mut io);
                exchange(companion, jobs, done);
            }
            if ll.due(now) {
                companion.low_level_step(&mut io);
            }
        }
        // Not flying: a heartbeat a second, as every MAVLink component (a simulator or a
        // router learns where the companion is from it; flying, the steps send them).
        if companion.flight().is_none() && last_beat.elapsed() >= Duration::from_secs(1) {
            last_beat = Instant::now();
            companion.heartbeat(&mut io);
        }
        if companion.mode() != mode {
            mode = companion.mode();
            on_mode(mode, companion.hold_reasons().0.into());
        }
        flush(link, &mut out)?;
    }
}

fn flush(link: &mut dyn Link, out: &mut Vec<Vec<u8>>) -> std::io::Result<()> {
    for frame in out.drain(..) {
        link.send(&frame)?;
    }
    Ok(())
}
