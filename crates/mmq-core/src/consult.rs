//! Consultation before a reward: when a robot of a swarm earns a reward, it must consult
//! before the reward is delivered to it, and the time that takes emerges from a radio
//! network.
//!
//! The network:
//!
//! - Its nodes are the robots `0..n` at `positions` (metres) and, for
//!   [`ConsultModel::Server`], a base station at a fixed position, node `n`.
//! - Two nodes are linked iff their Euclidean distance is at most [`Radio::range_m`] (a
//!   unit-disk graph). A robot at a non-finite position is linked to nothing.
//! - A message is relayed hop by hop along a shortest-hop path from the origin. Paths are
//!   deterministic: every node's parent is its lowest-index neighbour one hop closer to the
//!   origin. The base station answers but never relays.
//! - One hop traversal is a run of attempts until one gets through. Every attempt, lost or
//!   not, takes a latency drawn from [`Radio::hop`] (a lost attempt costs its latency as
//!   the sender's time-out before it retries) and is lost with probability [`Radio::loss`].
//!   After [`MAX_ATTEMPTS`] lost attempts on one hop the message is lost for good.
//!
//! The models ([`ConsultModel`]):
//!
//! - `Peers { k }`: the origin sends a request to every robot it can reach, and each peer
//!   replies along the same path back: 2·h hop traversals for a peer h hops away. The
//!   consultation completes with the k-th reply: its delay is the k-th smallest round-trip
//!   time. With fewer than k replies (peers out of reach, or messages lost) it never
//!   completes. `Peers { k: 0 }` asks nobody and completes at once (delay 0, no draws).
//! - `Server { x, y }`: one round trip to the base station at (x, y), relayed through the
//!   robots; never completes when the station is out of reach.
//!
//! Draw order, so that the same generator state always gives the same [`Consultation`]:
//! peers in index order (or the one server); for each, its request hops from the origin
//! outwards, then its reply hops back; within a hop, attempt by attempt, the latency and
//! then, when `loss > 0`, one uniform number u (the attempt is lost iff u < loss). A message
//! lost on one hop draws nothing for the hops after it. A network with no loss draws one
//! latency per hop and nothing else.
//!
//! Cost: O(n²) distance tests per consultation, and no allocation once the scratch buffers
//! of a [`Network`] have grown to the swarm's size, apart from [`Consultation::links`].

use rand::RngExt;

use crate::delay::{DelayDist, SecondsDist, SecondsSampler};
use crate::seed::Rng;

/// Most attempts spent on one hop; a message whose every attempt on a hop is lost is lost
/// for good (a peer that never replies, or a server that never answers).
pub const MAX_ATTEMPTS: u32 = 10_000;

/// Marks a node without a parent (the origin, or a node out of reach).
const NO_PARENT: usize = usize::MAX;

/// Whom a robot consults before its reward is delivered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConsultModel {
    /// Ask every reachable peer; complete with the k-th reply (k = 0: at once).
    Peers {
        /// Replies needed.
        k: usize,
    },
    /// One round trip to a base station at (x, y), metres.
    Server {
        /// Abscissa of the base station, metres.
        x: f64,
        /// Ordinate of the base station, metres.
        y: f64,
    },
}

/// The radio every node uses.
#[derive(Clone, Debug, PartialEq)]
pub struct Radio {
    /// Reach of a link, metres: nodes at most this far apart are linked.
    pub range_m: f64,
    /// Latency of one transmission attempt over one hop, seconds.
    pub hop: SecondsDist,
    /// Probability that one attempt is lost, in [0, 1).
    pub loss: f64,
}

impl Radio {
    /// Checks the radio: `range_m` finite and above 0, `loss` in [0, 1), and `hop` a delay
    /// the spec parser accepts (what [`crate::DelayDist::parse`] would build). The message
    /// names the field and how to fix it.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.range_m.is_finite() && self.range_m > 0.0) {
            return Err(format!(
                "radio range_m = {} must be a finite distance above 0 m; set it to the reach of one link, e.g. 3.0",
                self.range_m
            ));
        }
        if !(0.0..1.0).contains(&self.loss) {
            return Err(format!(
                "radio loss = {} must be in [0, 1): the probability that one attempt is lost (0 for a lossless radio)",
                self.loss
            ));
        }
        // The spec parser is the one judge of a usable delay: print the distribution as a
        // spec and parse it back.
        let spec = self.hop.to_string();
        match DelayDist::parse(&spec) {
            Ok(d) if d.as_seconds().is_some() => Ok(()),
            Ok(_) => Err(format!(
                "radio hop `{spec}` is not a delay in seconds; write it like exponential:0.05s, const:0.25s or wifi"
            )),
            Err(e) => Err(format!(
                "radio hop `{spec}` is not a usable per-hop latency: {}; write it like exponential:0.05s, const:0.25s or wifi",
                e.reason
            )),
        }
    }
}

/// The outcome of one consultation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Consultation {
    /// Seconds from the request to the reply that completes the consultation; `None` when
    /// it never completes (too few peers in reach, station out of reach, messages lost).
    pub delay_s: Option<f64>,
    /// One-way hop count of the reply that completes it (0 if none).
    pub hops: u32,
    /// Transmission attempts spent by every message sent, lost ones included, also those
    /// still travelling when the consultation completed.
    pub attempts: u32,
    /// Peers reachable at all, or 1 for a reachable base station (0 if not).
    pub reachable: u32,
    /// The distinct directed hops (from node, to node) of every path a message was sent
    /// along, sorted; the base station is node n. For drawing.
    pub links: Vec<(u32, u32)>,
}

/// A radio network that runs consultations, with scratch buffers reused between calls.
#[derive(Clone, Debug)]
pub struct Network {
    radio: Radio,
    sampler: SecondsSampler,
    /// Hop count from the origin of every node of the last search.
    hops: Vec<Option<u32>>,
    /// Parent of every node on its path from the origin ([`NO_PARENT`] if none).
    parent: Vec<usize>,
    /// Breadth-first queue.
    queue: Vec<usize>,
    /// Replies received: (round-trip seconds, one-way hops, peer).
    replies: Vec<(f64, u32, usize)>,
    /// Nodes whose parent hop a message used.
    used: Vec<bool>,
}

impl Network {
    /// A network over `radio`, or the reason the radio is unusable ([`Radio::validate`]).
    pub fn new(radio: Radio) -> Result<Network, String> {
        radio.validate()?;
        let sampler = radio.hop.sampler();
        Ok(Network {
            radio,
            sampler,
            hops: Vec::new(),
            parent: Vec::new(),
            queue: Vec::new(),
            replies: Vec::new(),
            used: Vec::new(),
        })
    }

    /// The radio of this network.
    pub fn radio(&self) -> &Radio {
        &self.radio
    }

    /// Hop counts from robot `origin` to every robot (index order) and, with a base station
    /// at `server`, to it last; `None` for a node out of reach. An origin that is not a
    /// robot (`origin >= positions.len()`) reaches nothing, not even itself.
    pub fn hop_counts(
        &mut self,
        origin: usize,
        positions: &[(f64, f64)],
        server: Option<(f64, f64)>,
    ) -> &[Option<u32>] {
        self.search(origin, positions, server);
        &self.hops
    }

    /// Runs one consultation of robot `origin` among the robots at `positions` (metres),
    /// drawing from `rng` in the order the module documents. An origin that is not a robot
    /// reaches nobody.
    pub fn consult(
        &mut self,
        model: &ConsultModel,
        origin: usize,
        positions: &[(f64, f64)],
        rng: &mut Rng,
    ) -> Consultation {
        let server = match *model {
            ConsultModel::Peers { .. } => None,
            ConsultModel::Server { x, y } => Some((x, y)),
        };
        self.search(origin, positions, server);
        self.used.clear();
        self.used.resize(self.hops.len(), false);
        let mut out = Consultation::default();
        match *model {
            ConsultModel::Peers { k } => {
                self.replies.clear();
                for peer in 0..positions.len() {
                    let Some(h) = self.hops[peer].filter(|_| peer != origin) else { continue };
                    out.reachable = out.reachable.saturating_add(1);
                    if k == 0 {
                        continue;
                    }
                    if let Some(rtt) = self.round_trip(peer, rng, &mut out.attempts) {
                        self.replies.push((rtt, h, peer));
                    }
                }
                if k == 0 {
                    out.delay_s = Some(0.0);
                } else if self.replies.len() >= k {
                    // Round-trip times, ties broken by peer index: a total order.
                    let (_, &mut (rtt, h, _), _) = self
                        .replies
                        .select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0).then(a.2.cmp(&b.2)));
                    out.delay_s = Some(rtt);
                    out.hops = h;
                }
            }
            ConsultModel::Server { .. } => {
                let station = positions.len();
                if let Some(h) = self.hops.get(station).copied().flatten() {
                    out.reachable = 1;
                    if let Some(rtt) = self.round_trip(station, rng, &mut out.attempts) {
                        out.delay_s = Some(rtt);
                        out.hops = h;
                    }
                }
            }
        }
        for v in 0..self.used.len() {
            if self.used[v] && self.parent[v] != NO_PARENT {
                let (u, v) = (self.parent[v] as u32, v as u32);
                out.links.push((u, v));
                out.links.push((v, u));
            }
        }
        out.links.sort_unstable();
        out
    }

    /// Breadth-first search from `origin`: fills `hops` and `parent` for the robots and,
    /// with a station, for node `positions.len()`.
    fn search(&mut self, origin: usize, positions: &[(f64, f64)], server: Option<(f64, f64)>) {
        let robots = positions.len();
        let n = robots + usize::from(server.is_some());
        let at = |i: usize| match (positions.get(i), server) {
            (Some(&p), _) => p,
            (None, Some(s)) => s,
            (None, None) => (f64::NAN, f64::NAN),
        };
        let range = self.radio.range_m;
        // A NaN distance compares false: a node at a non-finite position has no link.
        let linked = |a: usize, b: usize| {
            let (p, q) = (at(a), at(b));
            (p.0 - q.0).hypot(p.1 - q.1) <= range
        };
        self.hops.clear();
        self.hops.resize(n, None);
        self.parent.clear();
        self.parent.resize(n, NO_PARENT);
        self.queue.clear();
        if origin >= robots {
            return;
        }
        self.hops[origin] = Some(0);
        self.queue.push(origin);
        let mut head = 0;
        while let Some(&u) = self.queue.get(head) {
            head += 1;
            // The station answers but does not relay.
            if u >= robots {
                continue;
            }
            let next = self.hops[u].map_or(0, |h| h + 1);
            for v in 0..n {
                if self.hops[v].is_none() && linked(u, v) {
                    self.hops[v] = Some(next);
                    self.queue.push(v);
                }
            }
        }
        // Parent: the lowest-index robot one hop closer, whatever order the queue found it in.
        for v in 0..n {
            if let Some(h) = self.hops[v].filter(|&h| h > 0) {
                self.parent[v] =
                    (0..robots).find(|&u| self.hops[u] == Some(h - 1) && linked(u, v)).unwrap_or(NO_PARENT);
            }
        }
    }

    /// A request from the origin to `target` and the reply back along the same path; the
    /// round-trip seconds, or `None` when a hop runs out of attempts. Adds the attempts
    /// spent to `attempts` and marks the path's nodes as used.
    fn round_trip(&mut self, target: usize, rng: &mut Rng, attempts: &mut u32) -> Option<f64> {
        let h = self.hops.get(target).copied().flatten()?;
        // Every step goes one hop closer to the origin, so the walk ends within h steps.
        let mut v = target;
        while let Some(&u) = self.parent.get(v) {
            self.used[v] = true;
            v = u;
        }
        let mut total = 0.0;
        for _ in 0..h.saturating_mul(2) {
            let (t, spent) = traverse(&self.sampler, self.radio.loss, rng);
            *attempts = attempts.saturating_add(spent);
            total += t?;
        }
        Some(total)
    }
}

/// One hop traversal: attempts until one gets through. The seconds it took (`None` after
/// [`MAX_ATTEMPTS`] lost attempts) and the attempts spent.
fn traverse(sampler: &SecondsSampler, loss: f64, rng: &mut Rng) -> (Option<f64>, u32) {
    let mut t = 0.0;
    for attempt in 1..=MAX_ATTEMPTS {
        t += sampler.sample(rng);
        if loss == 0.0 || rng.random::<f64>() >= loss {
            return (Some(t), attempt);
        }
    }
    (None, MAX_ATTEMPTS)
}

#[cfg(test)]
mod tests {
    use rand::RngExt;

    use super::*;
    use crate::seed::rng_from_seed;

    fn secs(spec: &str) -> SecondsDist {
        DelayDist::parse(spec).unwrap().as_seconds().unwrap().clone()
    }

    fn network(range_m: f64, hop: &str, loss: f64) -> Network {
        Network::new(Radio { range_m, hop: secs(hop), loss }).unwrap()
    }

    const PEER: ConsultModel = ConsultModel::Peers { k: 1 };

    /// Robots uniform in a `side` × `side` square.
    fn swarm(n: usize, side: f64, rng: &mut Rng) -> Vec<(f64, f64)> {
        (0..n).map(|_| (side * rng.random::<f64>(), side * rng.random::<f64>())).collect()
    }

    /// Hop counts between all nodes by relaxation (Bellman–Ford on the unit-disk graph),
    /// independent of the breadth-first search under test; `u32::MAX` if out of reach.
    /// Node `relay_limit..` only receives (the station does not relay).
    fn all_hops(nodes: &[(f64, f64)], range: f64, relay_limit: usize) -> Vec<Vec<u32>> {
        let n = nodes.len();
        let link = |a: usize, b: usize| {
            let (p, q) = (nodes[a], nodes[b]);
            ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt() <= range
        };
        let mut d = vec![vec![u32::MAX; n]; n];
        for s in 0..n {
            d[s][s] = 0;
            for _ in 0..n {
                for u in 0..relay_limit.min(n) {
                    for v in 0..n {
                        if u != v && d[s][u] != u32::MAX && link(u, v) && d[s][u] + 1 < d[s][v] {
                            d[s][v] = d[s][u] + 1;
                        }
                    }
                }
            }
        }
        d
    }

    #[test]
    fn one_hop_round_trip_takes_two_latencies() {
        let mut net = network(1.5, "const:0.25s", 0.0);
        let c = net.consult(&PEER, 0, &[(0.0, 0.0), (1.0, 0.0)], &mut rng_from_seed(1));
        assert_eq!(c.delay_s, Some(0.5));
        assert_eq!((c.hops, c.attempts, c.reachable), (1, 2, 1));
        assert_eq!(c.links, vec![(0, 1), (1, 0)]);
    }

    #[test]
    fn two_hops_relay_through_the_middle_robot() {
        let d = 0.25;
        let chain = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)];
        let mut net = network(1.2, "const:0.25s", 0.0);
        let far = net.consult(&ConsultModel::Peers { k: 2 }, 0, &chain, &mut rng_from_seed(1));
        assert_eq!(far.delay_s, Some(4.0 * d));
        assert_eq!((far.hops, far.reachable), (2, 2));
        // 2 traversals to the near peer and back, 4 to the far one.
        assert_eq!(far.attempts, 6);
        assert_eq!(far.links, vec![(0, 1), (1, 0), (1, 2), (2, 1)]);
        let near = net.consult(&PEER, 0, &chain, &mut rng_from_seed(1));
        assert_eq!(near.delay_s, Some(2.0 * d));
        assert_eq!(near.hops, 1);
        // From the middle both peers are one hop away.
        let mid = net.consult(&ConsultModel::Peers { k: 2 }, 1, &chain, &mut rng_from_seed(1));
        assert_eq!((mid.delay_s, mid.hops), (Some(2.0 * d), 1));
        assert_eq!(net.hop_counts(0, &chain, None), &[Some(0), Some(1), Some(2)]);
    }

    #[test]
    fn isolated_robot_or_too_few_peers_never_completes() {
        let robots = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (10.0, 0.0)];
        let mut net = network(1.2, "const:0.25s", 0.0);
        let alone = net.consult(&PEER, 3, &robots, &mut rng_from_seed(1));
        assert_eq!(alone, Consultation { delay_s: None, hops: 0, attempts: 0, reachable: 0, links: vec![] });
        let short = net.consult(&ConsultModel::Peers { k: 3 }, 0, &robots, &mut rng_from_seed(1));
        assert_eq!((short.delay_s, short.hops, short.reachable), (None, 0, 2));
        // The requests were sent all the same.
        assert_eq!(short.attempts, 6);
        let huge = net.consult(&ConsultModel::Peers { k: usize::MAX }, 0, &robots, &mut rng_from_seed(1));
        assert_eq!(huge.delay_s, None);
    }

    #[test]
    fn server_round_trip_is_relayed_and_needs_reach() {
        let d = 0.25;
        let robots = [(0.0, 0.0), (1.0, 0.0)];
        let station = ConsultModel::Server { x: 2.0, y: 0.0 };
        let mut net = network(1.2, "const:0.25s", 0.0);
        let far = net.consult(&station, 0, &robots, &mut rng_from_seed(1));
        assert_eq!(far.delay_s, Some(4.0 * d));
        assert_eq!((far.hops, far.reachable, far.attempts), (2, 1, 4));
        assert_eq!(far.links, vec![(0, 1), (1, 0), (1, 2), (2, 1)]);
        let near = net.consult(&station, 1, &robots, &mut rng_from_seed(1));
        assert_eq!((near.delay_s, near.hops), (Some(2.0 * d), 1));
        assert_eq!(near.links, vec![(1, 2), (2, 1)]);
        let away = net.consult(&ConsultModel::Server { x: 5.0, y: 0.0 }, 0, &robots, &mut rng_from_seed(1));
        assert_eq!((away.delay_s, away.reachable, away.attempts), (None, 0, 0));
        // The station does not relay: robots 0 and 2 m apart stay apart through it.
        let split = [(0.0, 0.0), (2.0, 0.0)];
        assert_eq!(net.hop_counts(0, &split, Some((1.0, 0.0))), &[Some(0), None, Some(1)]);
    }

    #[test]
    fn draws_follow_the_documented_order() {
        // Peers 1 (1 hop), 2 (2 hops) and 3 (1 hop) of robot 0.
        let robots = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (0.0, 1.0)];
        let dist = secs("exponential:0.05s");
        for loss in [0.0, 0.5] {
            let mut net = Network::new(Radio { range_m: 1.2, hop: dist.clone(), loss }).unwrap();
            let sampler = dist.sampler();
            for seed in 0..20 {
                // By hand: peers in index order, 2·h hops each, latency then loss per attempt.
                let mut rng = rng_from_seed(seed);
                let mut rtt = Vec::new();
                let mut attempts = 0;
                for (peer, h) in [(1, 1), (2, 2), (3, 1)] {
                    let mut t = 0.0;
                    for _ in 0..2 * h {
                        let mut hop = 0.0;
                        loop {
                            attempts += 1;
                            hop += sampler.sample(&mut rng);
                            if loss == 0.0 || rng.random::<f64>() >= loss {
                                break;
                            }
                        }
                        t += hop;
                    }
                    rtt.push((t, h, peer));
                }
                let after = rng.random::<u64>();
                rtt.sort_by(|a, b| a.0.total_cmp(&b.0));
                for k in 1..=3 {
                    let mut rng = rng_from_seed(seed);
                    let c = net.consult(&ConsultModel::Peers { k }, 0, &robots, &mut rng);
                    assert_eq!(c.delay_s, Some(rtt[k - 1].0));
                    assert_eq!(c.hops, rtt[k - 1].1);
                    assert_eq!(c.attempts, attempts);
                    assert_eq!(rng.random::<u64>(), after, "consult drew more or less than documented");
                }
            }
        }
    }

    #[test]
    fn lost_attempts_cost_their_latency() {
        // One hop, constant latency d, loss p: each traversal takes N·d with N geometric on
        // {1, 2, ...}, mean 1/(1−p), variance p/(1−p)². A round trip is two of them.
        let (d, p, runs) = (0.1, 0.3, 20_000);
        let mut net = network(1.5, "const:0.1s", p);
        let mut rng = rng_from_seed(7);
        let (mut sum, mut tries) = (0.0, 0.0);
        for _ in 0..runs {
            let c = net.consult(&PEER, 0, &[(0.0, 0.0), (1.0, 0.0)], &mut rng);
            let delay = c.delay_s.unwrap();
            // Every attempt, lost or not, costs exactly d.
            assert!((delay - d * f64::from(c.attempts)).abs() < 1e-9);
            sum += delay;
            tries += f64::from(c.attempts);
        }
        let n = runs as f64;
        let (mean_n, var_n) = (1.0 / (1.0 - p), p / (1.0 - p).powi(2));
        // Four standard errors of the mean of a sum of two independent traversals.
        let se_delay = (2.0 * d * d * var_n / n).sqrt();
        let mean = sum / n;
        assert!((mean - 2.0 * d * mean_n).abs() < 4.0 * se_delay, "mean delay {mean}");
        let se_tries = (2.0 * var_n / n).sqrt();
        assert!((tries / n - 2.0 * mean_n).abs() < 4.0 * se_tries, "mean attempts {}", tries / n);
    }

    #[test]
    fn server_delay_matches_the_hop_count_in_a_random_swarm() {
        // 16 robots in a 9 m × 9 m square, range 3 m, the station in a corner. A completed
        // round trip over h hops is 2h independent traversals; with exponential latency of
        // mean m and loss p, a traversal (a geometric number of exponential attempts) is
        // exponential with mean m/(1−p), variance (m/(1−p))². So Σ delay over all completed
        // consultations has mean μ·Σ2h and variance μ²·Σ2h: the test allows 4 standard
        // deviations (a false alarm about once in 16,000 seeds; the seed is fixed anyway).
        let (m, p) = (0.05, 0.1);
        let mut net = network(3.0, "exponential:0.05s", p);
        let station = (0.0, 0.0);
        let model = ConsultModel::Server { x: station.0, y: station.1 };
        let mut rng = rng_from_seed(11);
        let (mut delay, mut traversals, mut tries, mut done, mut missed) = (0.0, 0.0, 0.0, 0, 0);
        let mut deepest = 0;
        for _ in 0..200 {
            let robots = swarm(16, 9.0, &mut rng);
            let mut nodes = robots.clone();
            nodes.push(station);
            let truth = all_hops(&nodes, 3.0, robots.len());
            for origin in 0..robots.len() {
                let c = net.consult(&model, origin, &robots, &mut rng);
                let h = truth[origin][robots.len()];
                if h == u32::MAX {
                    assert_eq!((c.delay_s, c.reachable, c.attempts), (None, 0, 0));
                    missed += 1;
                    continue;
                }
                // Loss past the attempt bound has probability 0.1^10000: never.
                let d = c.delay_s.unwrap();
                assert_eq!((c.hops, c.reachable), (h, 1), "hops must be the shortest path");
                assert_eq!(c.links.len(), 2 * h as usize);
                delay += d;
                traversals += 2.0 * f64::from(h);
                tries += f64::from(c.attempts);
                done += 1;
                deepest = deepest.max(h);
            }
        }
        assert!(
            done > 1000 && missed > 0 && deepest >= 4,
            "{done} done, {missed} out of reach, {deepest} hops"
        );
        let mu = m / (1.0 - p);
        let z = (delay - mu * traversals) / (mu * traversals.sqrt());
        assert!(z.abs() < 4.0, "delay z = {z}");
        // Attempts per traversal: geometric, mean 1/(1−p), variance p/(1−p)².
        let z = (tries - traversals / (1.0 - p)) / (traversals * p).sqrt() * (1.0 - p);
        assert!(z.abs() < 4.0, "attempts z = {z}");
    }

    #[test]
    fn peers_take_the_kth_nearest_over_lowest_index_parents() {
        // With a constant latency d and no loss, a peer h hops away replies after 2h·d: the
        // k-th reply comes from the k-th smallest hop count. The links are exactly the
        // parent hops (lowest-index neighbour one hop closer) of every reachable peer.
        let d = 0.25;
        let mut net = network(3.0, "const:0.25s", 0.0);
        let mut rng = rng_from_seed(3);
        for _ in 0..60 {
            let robots = swarm(16, 9.0, &mut rng);
            let truth = all_hops(&robots, 3.0, robots.len());
            let linked = |a: usize, b: usize| {
                let (p, q) = (robots[a], robots[b]);
                ((p.0 - q.0).powi(2) + (p.1 - q.1).powi(2)).sqrt() <= 3.0
            };
            for origin in 0..robots.len() {
                let row = &truth[origin];
                let mut near: Vec<u32> = (0..robots.len())
                    .filter(|&v| v != origin && row[v] != u32::MAX)
                    .map(|v| row[v])
                    .collect();
                near.sort_unstable();
                let mut links = Vec::new();
                for v in 0..robots.len() {
                    if v != origin && row[v] != u32::MAX {
                        let u = (0..robots.len())
                            .find(|&u| row[u].checked_add(1) == Some(row[v]) && linked(u, v))
                            .unwrap();
                        links.extend([(u as u32, v as u32), (v as u32, u as u32)]);
                    }
                }
                links.sort_unstable();
                for k in [1, 2, 5, 15] {
                    let c = net.consult(&ConsultModel::Peers { k }, origin, &robots, &mut rng);
                    assert_eq!(c.reachable as usize, near.len());
                    assert_eq!(c.links, links);
                    match near.get(k - 1) {
                        Some(&h) => assert_eq!((c.delay_s, c.hops), (Some(2.0 * f64::from(h) * d), h)),
                        None => assert_eq!((c.delay_s, c.hops), (None, 0)),
                    }
                }
            }
        }
    }

    #[test]
    fn same_seed_same_consultation() {
        let mut net = network(3.0, "exponential:0.05s", 0.1);
        let robots = swarm(16, 9.0, &mut rng_from_seed(5));
        for model in [ConsultModel::Peers { k: 3 }, ConsultModel::Server { x: 4.5, y: 4.5 }] {
            let a = net.consult(&model, 2, &robots, &mut rng_from_seed(9));
            let b = net.consult(&model, 2, &robots, &mut rng_from_seed(9));
            let other = net.consult(&model, 2, &robots, &mut rng_from_seed(10));
            assert!(a.delay_s.is_some());
            assert_eq!(a, b);
            assert_ne!(a.delay_s, other.delay_s);
        }
    }

    #[test]
    fn a_hop_out_of_attempts_loses_the_message() {
        let mut net = network(1.5, "const:0.01s", 1.0 - 1e-12);
        let robots = [(0.0, 0.0), (1.0, 0.0)];
        for model in [PEER, ConsultModel::Server { x: 1.0, y: 1.0 }] {
            let c = net.consult(&model, 0, &robots, &mut rng_from_seed(1));
            assert_eq!((c.delay_s, c.hops, c.reachable), (None, 0, 1));
            // The request's first hop spent every attempt; the reply was never sent.
            assert_eq!(c.attempts, MAX_ATTEMPTS);
        }
    }

    #[test]
    fn odd_inputs_give_answers_not_panics() {
        let mut net = network(1.5, "exponential:0.05s", 0.2);
        let mut rng = rng_from_seed(1);
        let robots = [(0.0, 0.0), (1.0, 0.0), (f64::NAN, 0.0), (f64::INFINITY, 1.0)];
        for model in [
            ConsultModel::Peers { k: 1 },
            ConsultModel::Peers { k: 0 },
            ConsultModel::Server { x: f64::NAN, y: 0.0 },
            ConsultModel::Server { x: 0.5, y: 0.0 },
        ] {
            for origin in [0, 2, 3, 4, usize::MAX] {
                let c = net.consult(&model, origin, &robots, &mut rng);
                assert!(c.delay_s.is_none_or(|d| d.is_finite() && d >= 0.0));
                let _ = net.consult(&model, origin, &[], &mut rng);
            }
        }
        // The non-finite robots reach nobody.
        assert_eq!(net.consult(&PEER, 2, &robots, &mut rng).reachable, 0);
        assert_eq!(net.hop_counts(9, &robots, None), &[None, None, None, None]);
        // k = 0 asks nobody: at once, drawing nothing.
        let before = rng.clone();
        let c = net.consult(&ConsultModel::Peers { k: 0 }, 0, &robots, &mut rng);
        assert_eq!((c.delay_s, c.hops, c.attempts, c.reachable), (Some(0.0), 0, 0, 1));
        assert!(c.links.is_empty());
        assert_eq!(rng, before);
    }

    #[test]
    fn bad_radios_are_refused_with_the_field_named() {
        let good = Radio { range_m: 3.0, hop: secs("wifi"), loss: 0.1 };
        assert!(good.validate().is_ok());
        for range_m in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = Network::new(Radio { range_m, ..good.clone() }).unwrap_err();
            assert!(e.contains("range_m"), "{e}");
        }
        for loss in [1.0, -0.1, f64::NAN] {
            let e = Radio { loss, ..good.clone() }.validate().unwrap_err();
            assert!(e.contains("loss"), "{e}");
        }
        for hop in [
            SecondsDist::Exponential(-1.0),
            SecondsDist::Constant(f64::NAN),
            SecondsDist::LogNormal { median: 0.0, sigma: 1.0 },
            SecondsDist::Uniform(2.0, 1.0),
            SecondsDist::Mixture(vec![]),
            SecondsDist::Histogram { bin_s: 0.5, weights: vec![0.0] },
        ] {
            let e = Radio { hop, ..good.clone() }.validate().unwrap_err();
            assert!(e.contains("radio hop"), "{e}");
        }
    }
}
