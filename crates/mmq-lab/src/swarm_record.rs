//! Recording a swarm's seed: the [`SwarmRecorder`] the seed's observer factory opened,
//! fed by the swarm's loop during learning (not during the greedy evaluation) with every
//! frame of the robots' poses and every robot's step, in simulated-time order.
//!
//! The recorder reaches the seed as its observer and is taken back here as its own type
//! ([`mmq_core::Observer::into_any`]); it may also show the swarm in the live view, or
//! only that (`SwarmRecorder::live_only`). Any other observer is refused.

use mmq_core::{Env, Observer, RunInfo, State, World};
use mmq_log::{SwarmDelivery, SwarmRecorder, SwarmSetup, SwarmStepIn};
use mmq_robot::RobotEnv;
use mmq_robot::swarm::{Consult, SwarmEnv, SwarmFrame, SwarmStep};

use crate::config::RunConfig;
use crate::error::LabError;

/// A swarm seed's recording.
pub(crate) struct Recording {
    rec: Box<SwarmRecorder>,
    facts: Vec<(String, String)>,
    frames: Vec<SwarmFrame>,
    deliveries: Vec<SwarmDelivery>,
}

impl Recording {
    /// Takes the seed's observer back as the swarm's recorder; `facts` are the run's
    /// (versions, physics), written into its `run` metadata.
    pub fn new(observer: Box<dyn Observer + Send>, facts: Vec<(String, String)>) -> Result<Self, LabError> {
        match observer.into_any().and_then(|a| a.downcast::<SwarmRecorder>().ok()) {
            Some(rec) => Ok(Recording { rec, facts, frames: Vec::new(), deliveries: Vec::new() }),
            None => Err(LabError::param(
                "record",
                "on",
                "the swarm is recorded by its own recorder; this observer is not one",
            )),
        }
    }

    /// Asks `env` for frames at the recorder's rate, from its next reset on.
    pub fn trace(&self, env: &mut SwarmEnv) {
        env.set_trace(Some(self.rec.frame_period_s()));
    }

    /// The run's start (after the reset): metadata, attachments, scenes.
    pub fn start(
        &mut self,
        env: &SwarmEnv,
        cfg: &RunConfig,
        world: &World,
        seed: u64,
    ) -> Result<(), LabError> {
        let names = RobotEnv::new(world, env.config().clone())
            .map_err(|e| LabError::EnvBuild(e.to_string()))?
            .action_names();
        let station = match env.swarm().consult {
            Consult::Server { cell } => Some(world.cell_center(cell)),
            _ => None,
        };
        let config_toml = cfg.to_toml();
        let info = RunInfo {
            world,
            seed,
            learner: cfg.learner.kind().name(),
            action_names: &names,
            config_toml: &config_toml,
            env_kind: cfg.env.name(),
            facts: &self.facts,
            start_pose: None,
        };
        let estimates = env.estimates().iter().any(Option::is_some);
        let setup = SwarmSetup { robots: env.robots(), station, estimates };
        self.rec.start(&info, setup, env.time_s());
        Ok(())
    }

    /// The frames `env` sampled since the last call.
    pub fn frames(&mut self, env: &mut SwarmEnv) {
        env.take_frames(&mut self.frames);
        for f in &self.frames {
            self.rec.frame(f.time_s, &f.poses, &f.estimates);
        }
    }

    /// Robot `st.robot`'s step, decided in `state` with `action` (`model`, `explored`:
    /// how the learner chose it).
    pub fn step(
        &mut self,
        st: &SwarmStep,
        state: State,
        action: usize,
        model: Option<usize>,
        explored: bool,
    ) {
        self.deliveries.clear();
        self.deliveries.extend(st.deliveries.iter().map(|d| SwarmDelivery {
            t_emit: d.decision,
            value: d.value,
            t_emit_s: d.emitted_s,
            delay_s: d.delay_s,
            hops: d.hops,
        }));
        self.rec.step(&SwarmStepIn {
            robot: st.robot,
            t: st.decision,
            time_s: st.time_s,
            state,
            action,
            model,
            explored,
            next_state: st.step.state,
            event: st.step.event,
            earned: st.step.reward,
            delivered: st.delivered,
            deliveries: &self.deliveries,
            consultation: st.consultation,
            links: &st.links,
            nodes: &st.nodes,
        });
    }

    /// The first write that failed so far, if any.
    pub fn error(&self) -> Option<String> {
        self.rec.error()
    }

    /// Finishes the file; a write that failed is the seed's failure.
    pub fn finish(mut self, complete: bool) -> Option<String> {
        self.rec.finish(complete).err().map(|e| format!("the recording was not written whole: {e}"))
    }
}
