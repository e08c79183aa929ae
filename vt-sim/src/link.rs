//! Link model for neighbours' positions: per-message delay and drop probability, seeded.
//! Each UAV sees, for each other UAV, the last position it received and that message's age;
//! entries older than the stale timeout are reported missing (`None`).

use std::collections::VecDeque;

/// Deterministic SplitMix64 generator (same seed, same draws, on every platform).
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// Generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Neighbour-position link between `n` UAVs, stepped at the high-level rate.
#[derive(Debug, Clone)]
pub struct Link<T: Copy> {
    n: usize,
    delay_steps: u64,
    jitter_steps: u64,
    drop_probability: f64,
    silent: Vec<bool>,
    /// Receivers whose link died: nothing reaches them.
    deaf: Vec<bool>,
    stale_steps: u64,
    rng: SplitMix64,
    /// In flight, per (receiver, sender): (delivery step, stamp step, payload).
    queues: Vec<VecDeque<(u64, u64, T)>>,
    /// Last received per (receiver, sender): (stamp step, payload).
    latest: Vec<Option<(u64, T)>>,
    /// Ideal link (no delay, jitter, drops or silenced sender): every receiver has what each
    /// sender broadcast last, kept once per sender in `broadcast` (O(n) per exchange instead of
    /// O(n^2)). Left for the per-pair model, with the same contents, the moment that stops
    /// being true.
    ideal: bool,
    /// Last broadcast per sender (ideal mode): (stamp step, payload).
    broadcast: Vec<Option<(u64, T)>>,
}

impl<T: Copy> Link<T> {
    /// A link with delay and staleness in high-level steps.
    pub fn new(n: usize, delay_steps: u64, drop_probability: f64, stale_steps: u64, seed: u64) -> Self {
        Self {
            n,
            delay_steps,
            jitter_steps: 0,
            drop_probability,
            silent: vec![false; n],
            deaf: vec![false; n],
            stale_steps,
            rng: SplitMix64::new(seed ^ 0x4C49_4E4B),
            queues: vec![VecDeque::new(); n * n],
            latest: vec![None; n * n],
            ideal: delay_steps == 0 && drop_probability <= 0.0,
            broadcast: vec![None; n],
        }
    }

    /// Leaves ideal mode: every (receiver, sender) entry gets what the sender broadcast last.
    fn leave_ideal(&mut self) {
        if !self.ideal {
            return;
        }
        self.ideal = false;
        for rx in 0..self.n {
            for (tx, b) in self.broadcast.iter().enumerate() {
                if tx != rx {
                    if let Some(slot) = self.latest.get_mut(rx * self.n + tx) {
                        *slot = *b;
                    }
                }
            }
        }
    }

    /// Adds a random extra delay, uniform in `0..=jitter_steps`, to every message.
    pub fn with_jitter(mut self, jitter_steps: u64) -> Self {
        self.jitter_steps = jitter_steps;
        if jitter_steps > 0 {
            self.leave_ideal();
        }
        self
    }

    /// UAV `tx` stops transmitting (fault): nothing it sends arrives from now on.
    pub fn silence(&mut self, tx: usize) {
        self.leave_ideal();
        if let Some(s) = self.silent.get_mut(tx) {
            *s = true;
        }
    }

    /// UAV `i`'s link dies (fault): from now on nothing it sends arrives and nothing reaches it;
    /// messages in flight to or from it are lost.
    pub fn kill(&mut self, i: usize) {
        self.leave_ideal();
        if let (Some(s), Some(d)) = (self.silent.get_mut(i), self.deaf.get_mut(i)) {
            *s = true;
            *d = true;
        }
        for other in 0..self.n {
            for k in [i * self.n + other, other * self.n + i] {
                if let Some(q) = self.queues.get_mut(k) {
                    q.clear();
                }
            }
        }
    }

    /// Every UAV broadcasts its payload at step `now`; messages due are delivered.
    pub fn exchange(&mut self, now: u64, payloads: &[T]) {
        if self.ideal {
            for (b, p) in self.broadcast.iter_mut().zip(payloads) {
                *b = Some((now, *p));
            }
            return;
        }
        for rx in 0..self.n {
            for (tx, p) in payloads.iter().enumerate().take(self.n) {
                if tx == rx {
                    continue;
                }
                let k = rx * self.n + tx;
                let silent = self.silent.get(tx).copied().unwrap_or(false) || self.deaf.get(rx).copied().unwrap_or(false);
                let lost = silent || (self.drop_probability > 0.0 && self.rng.next_f64() < self.drop_probability);
                let jitter = if self.jitter_steps > 0 { self.rng.next_u64() % (self.jitter_steps + 1) } else { 0 };
                if let Some(q) = self.queues.get_mut(k) {
                    if !lost && self.delay_steps == 0 && jitter == 0 && q.is_empty() {
                        // Due now and nothing ahead of it: the queue would take it and hand it
                        // straight back. Same result, no queue traffic (the common case).
                        if let Some(slot) = self.latest.get_mut(k) {
                            *slot = Some((now, *p));
                        }
                        continue;
                    }
                    if !lost {
                        // Keep arrival order monotone per sender (a later message never
                        // overtakes an earlier one on a serial link).
                        let due = (now + self.delay_steps + jitter).max(q.back().map_or(0, |m| m.0));
                        q.push_back((due, now, *p));
                    }
                    while q.front().is_some_and(|m| m.0 <= now) {
                        if let (Some((_, stamp, v)), Some(slot)) = (q.pop_front(), self.latest.get_mut(k)) {
                            *slot = Some((stamp, v));
                        }
                    }
                }
            }
        }
    }

    /// What receiver `rx` knows of every UAV at step `now` (own slot: `own`).
    pub fn view(&self, rx: usize, now: u64, own: T, out: &mut Vec<Option<T>>) {
        out.clear();
        for tx in 0..self.n {
            if tx == rx {
                out.push(Some(own));
                continue;
            }
            let entry = if self.ideal { self.broadcast.get(tx) } else { self.latest.get(rx * self.n + tx) };
            let v = entry
                .copied()
                .flatten()
                .and_then(|(stamp, v)| (now.saturating_sub(stamp) <= self.stale_steps).then_some(v));
            out.push(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ideal_mode_is_the_per_pair_model() {
        // Same link twice, one forced out of ideal mode from the start: identical views at
        // every step, before and after a sender is silenced.
        let mut a = Link::new(4, 0, 0.0, 3, 9);
        let mut b = Link::new(4, 0, 0.0, 3, 9);
        b.leave_ideal();
        assert!(a.ideal && !b.ideal);
        let (mut va, mut vb) = (Vec::new(), Vec::new());
        for k in 0..20u64 {
            if k == 7 {
                a.silence(2);
                b.silence(2);
            }
            let p = [k, 10 + k, 20 + k, 30 + k];
            a.exchange(k, &p);
            b.exchange(k, &p);
            for rx in 0..4 {
                a.view(rx, k, 99, &mut va);
                b.view(rx, k, 99, &mut vb);
                assert_eq!(va, vb, "step {k} receiver {rx}");
            }
        }
        a.view(0, 19, 99, &mut va);
        assert_eq!(va[2], None, "silenced sender stale after the timeout");
    }

    #[test]
    fn zero_delay_delivers_immediately() {
        let mut l = Link::new(3, 0, 0.0, 5, 1);
        l.exchange(0, &[1, 2, 3]);
        let mut v = Vec::new();
        l.view(0, 0, 10, &mut v);
        assert_eq!(v, vec![Some(10), Some(2), Some(3)]);
    }

    #[test]
    fn delay_and_staleness() {
        let mut l = Link::new(2, 2, 0.0, 3, 1);
        let mut v = Vec::new();
        l.exchange(0, &[1, 2]);
        l.view(0, 0, 0, &mut v);
        assert_eq!(v[1], None);
        l.exchange(1, &[1, 3]);
        l.exchange(2, &[1, 4]);
        l.view(0, 2, 0, &mut v);
        assert_eq!(v[1], Some(2), "message of step 0 arrives at step 2");
        // Nothing more sent: stale after 3 steps past its stamp... keep exchanging with drops.
        let mut l2 = Link::new(2, 0, 0.0, 3, 1);
        l2.exchange(0, &[1, 2]);
        l2.view(0, 3, 0, &mut v);
        assert_eq!(v[1], Some(2));
        l2.view(0, 4, 0, &mut v);
        assert_eq!(v[1], None);
    }

    #[test]
    fn silenced_sender_goes_stale() {
        let mut l = Link::new(2, 0, 0.0, 2, 1);
        let mut v = Vec::new();
        l.exchange(0, &[1, 2]);
        l.silence(1);
        for k in 1..4 {
            l.exchange(k, &[1, 2]);
        }
        l.view(0, 3, 0, &mut v);
        assert_eq!(v[1], None, "silent UAV must go stale");
        l.view(1, 3, 0, &mut v);
        assert_eq!(v[0], Some(1), "the silent UAV still hears the others");
    }

    #[test]
    fn a_dead_link_neither_sends_nor_receives() {
        let mut l = Link::new(3, 1, 0.0, 2, 1);
        let mut v = Vec::new();
        l.exchange(0, &[1, 2, 3]);
        l.kill(1); // the messages of step 0 to and from UAV 1 are still in flight: lost
        for k in 1..5 {
            l.exchange(k, &[1, 2, 3]);
        }
        l.view(0, 4, 0, &mut v);
        assert_eq!(v, vec![Some(0), None, Some(3)], "nothing from the dead UAV");
        l.view(1, 4, 0, &mut v);
        assert_eq!(v, vec![None, Some(0), None], "nothing reaches the dead UAV");
        l.view(2, 4, 0, &mut v);
        assert_eq!(v[0], Some(1), "the others still hear each other");
    }

    #[test]
    fn drops_are_seeded_and_at_the_requested_rate() {
        let run = |seed| {
            let mut l = Link::new(2, 0, 0.3, 1000, seed);
            let mut got = 0;
            let mut v = Vec::new();
            for k in 0..10_000u64 {
                l.exchange(k, &[k, k]);
                l.view(0, k, 0, &mut v);
                if v[1] == Some(k) {
                    got += 1;
                }
            }
            got
        };
        assert_eq!(run(7), run(7));
        let rate = 1.0 - run(7) as f64 / 10_000.0;
        assert!((rate - 0.3).abs() < 0.02, "drop rate {rate}");
    }
}
