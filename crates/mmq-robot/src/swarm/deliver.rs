//! The swarm's post: every nonzero reward a robot earns starts a consultation over the
//! radio (from the robots' positions when it is earned); the reward is delivered to its
//! robot at the robot's first decision that ends at or after the consultation completes.
//! A consultation that can never complete (too few peers in reach, the base station out
//! of reach) loses its reward, and the ledger says so.
//!
//! Zero rewards need no consultation (they change no sum). With `consult = "none"` a
//! reward is delivered at the decision that earned it, as on the single robot without a
//! delay.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use mmq_core::consult::{ConsultModel, Network, Radio};
use mmq_core::seed::rng_from_seed;
use mmq_core::{Rng, State, Step, World};

use super::config::{Consult, SwarmConfig};
use crate::config::RobotError;

/// A reward delivered to a robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Delivery {
    /// The robot's decision step that earned it.
    pub decision: u64,
    /// Its value.
    pub value: f64,
    /// When it was earned, simulated seconds.
    pub emitted_s: f64,
    /// How long its consultation took, seconds (0 without consultation).
    pub delay_s: f64,
    /// One-way hops of the reply that completed the consultation.
    pub hops: u32,
}

/// One robot's step that ended.
#[derive(Clone, Debug, PartialEq)]
pub struct SwarmStep {
    /// The robot.
    pub robot: usize,
    /// The robot's decision step that ended (0, 1, …).
    pub decision: u64,
    /// The state reached, the reward earned (before any consultation) and the event.
    pub step: Step,
    /// Simulated time at the end of the step, seconds.
    pub time_s: f64,
    /// The sum delivered to the robot at this decision.
    pub delivered: f64,
    /// What was delivered, oldest first.
    pub deliveries: Vec<Delivery>,
    /// The earned reward's consultation: `Some(delay, hops)`, or `None` when it will
    /// never complete (the reward is lost) or the reward is zero.
    pub consultation: Option<(f64, u32)>,
    /// The radio hops (from node, to node) the earned reward's consultation sent
    /// messages over, for drawing; robots are nodes `0..robots`, the base station is
    /// node `robots`. Empty without a consultation.
    pub links: Vec<(u32, u32)>,
    /// Where the nodes of `links` were when the consultation was routed, metres: every
    /// robot in order, then the base station if there is one. Empty without links.
    pub nodes: Vec<(f64, f64)>,
}

impl SwarmStep {
    /// The state reached.
    pub fn state(&self) -> State {
        self.step.state
    }
}

/// The delays that emerged for one robot.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RobotDelays {
    /// Nonzero rewards earned.
    pub emitted: u64,
    /// Delivered so far.
    pub delivered: u64,
    /// Lost: their consultation can never complete.
    pub lost: u64,
    /// Every completed consultation's delay, seconds, in the order earned.
    pub delays_s: Vec<f32>,
    /// The one-way hops of each completed consultation, in the same order.
    pub hops: Vec<u8>,
}

/// A reward waiting for its consultation to complete.
#[derive(Clone, Copy, Debug)]
struct Pending {
    due_s: f64,
    seq: u64,
    delivery: Delivery,
}

impl PartialEq for Pending {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Pending {}
impl PartialOrd for Pending {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Pending {
    /// Earliest due first (a max-heap of reversed order), then first earned.
    fn cmp(&self, o: &Self) -> Ordering {
        o.due_s.total_cmp(&self.due_s).then(o.seq.cmp(&self.seq))
    }
}

/// The consultations and the rewards in flight.
pub(super) struct Post {
    model: Option<ConsultModel>,
    network: Network,
    rng: Rng,
    inbox: Vec<BinaryHeap<Pending>>,
    delays: Vec<RobotDelays>,
    seq: u64,
}

impl Post {
    pub fn new(swarm: &SwarmConfig, world: &World) -> Result<Post, RobotError> {
        let model = match swarm.consult {
            Consult::None => None,
            Consult::Peers { k } => Some(ConsultModel::Peers { k }),
            Consult::Server { cell } => {
                let (x, y) = world.cell_center(cell);
                Some(ConsultModel::Server { x, y })
            }
        };
        let radio = Radio { range_m: swarm.radio_range_m, hop: swarm.hop_delay.clone(), loss: swarm.loss };
        let network = Network::new(radio)
            .map_err(|message| RobotError::Parse { message: format!("[swarm]: {message}") })?;
        Ok(Post { model, network, rng: rng_from_seed(0), inbox: Vec::new(), delays: Vec::new(), seq: 0 })
    }

    pub fn reset(&mut self, seed: u64, robots: usize) {
        self.rng = rng_from_seed(seed);
        self.inbox = (0..robots).map(|_| BinaryHeap::new()).collect();
        self.delays = vec![RobotDelays::default(); robots];
        self.seq = 0;
    }

    /// Posts robot `robot`'s reward of decision `decision` (earned at `now`) and
    /// collects what is due for it.
    pub fn after_step(
        &mut self,
        robot: usize,
        decision: u64,
        now: f64,
        step: Step,
        positions: &[(f64, f64)],
    ) -> SwarmStep {
        let mut consultation = None;
        let mut links = Vec::new();
        let mut nodes = Vec::new();
        if step.reward != 0.0 {
            let d = &mut self.delays[robot];
            d.emitted += 1;
            let (delay, hops) = match &self.model {
                None => (Some(0.0), 0),
                Some(model) => {
                    let c = self.network.consult(model, robot, positions, &mut self.rng);
                    links = c.links;
                    if !links.is_empty() {
                        nodes.extend_from_slice(positions);
                        if let ConsultModel::Server { x, y } = model {
                            nodes.push((*x, *y));
                        }
                    }
                    (c.delay_s, c.hops)
                }
            };
            match delay {
                Some(delay_s) => {
                    d.delays_s.push(delay_s as f32);
                    d.hops.push(hops.min(u8::MAX as u32) as u8);
                    consultation = Some((delay_s, hops));
                    let delivery = Delivery { decision, value: step.reward, emitted_s: now, delay_s, hops };
                    self.inbox[robot].push(Pending { due_s: now + delay_s, seq: self.seq, delivery });
                    self.seq += 1;
                }
                None => d.lost += 1,
            }
        }
        let mut deliveries = Vec::new();
        let mut delivered = 0.0;
        while self.inbox[robot].peek().is_some_and(|p| p.due_s <= now) {
            if let Some(p) = self.inbox[robot].pop() {
                delivered += p.delivery.value;
                deliveries.push(p.delivery);
            }
        }
        self.delays[robot].delivered += deliveries.len() as u64;
        SwarmStep { robot, decision, step, time_s: now, delivered, deliveries, consultation, links, nodes }
    }

    pub fn delays(&self) -> &[RobotDelays] {
        &self.delays
    }

    pub fn in_flight(&self) -> Vec<(u64, f64)> {
        self.inbox.iter().map(|h| (h.len() as u64, h.iter().map(|p| p.delivery.value).sum())).collect()
    }
}
