//! mmq-learn: learners that see only (s, a, s', delivered reward, the step's simulated
//! time), one file per algorithm, each reading like the paper with its equation numbers.
//!
//! | learner | file | paper |
//! |---|---|---|
//! | `q` | [`qlearning`] | eq. (2) |
//! | `fixed` | [`fixed_delay`] | eq. (4) |
//! | `mmq` | [`mmq`] (fast) / [`mmq_reference`] (plain transcription) | Algorithm 1, eqs. (5)–(7) |
//! | `mmq-kernel` | [`mmq_kernel`] | Algorithm 1 with kernel credit around the leading model (the paper's future work) and other bootstraps |
//! | `q-lambda` | [`q_lambda`] | Watkins's Q(λ) |
//! | `sarsa-lambda` | [`sarsa_lambda`] | SARSA(λ) |
//! | `oracle` | [`oracle`] | true credit from the channel's ledger: an upper bound, no real agent |
//! | `deconv-q` | [`deconv_q`] + [`deconv`] | Q-learning on deconvolved rewards, delay pmf estimated |
//! | `deconv-model` | [`deconv_model`] + [`deconv`] | counted model + deconvolved rewards + value iteration |
//! | `deconv-model-time` | [`deconv_model_time`] | `deconv-model` with its delay pmf over bins of simulated time |
//!
//! Architecture invariant: learners know no environment, no physics, no log format;
//! exploration randomness comes in from the caller's stream.
//!
//! Shared by every learner: the core types ([`learner`]: [`Learner`], [`Decision`],
//! [`Experience`], [`Table`]), one trajectory's memory for parameter sharing
//! ([`memory`]), the shared parameters ([`params`]), the delay estimate a
//! learner reports ([`diagnostics`], [`pmf`]) and tabular helpers ([`table`], [`policy`]).
//! Selection: [`kind`] (which learner), [`settings`] (each learner's own settings, tagged
//! by kind, each struct defined beside its learner) and [`spec`] (settings and parameters,
//! validated, built). This file only declares modules and re-exports; no module imports
//! another in a circle (the workspace's `tests/it/import_cycles.rs`).

pub mod decode;
pub mod deconv;
pub mod deconv_model;
pub mod deconv_model_time;
pub mod deconv_q;
pub mod diagnostics;
pub mod error;
pub mod fixed_delay;
pub mod kind;
pub mod learner;
pub mod memory;
pub mod mmq;
pub mod mmq_kernel;
pub mod mmq_reference;
pub mod oracle;
pub mod params;
pub mod pmf;
pub mod policy;
pub mod q_lambda;
pub mod qlearning;
pub mod sarsa_lambda;
pub mod settings;
pub mod spare;
pub mod spec;
mod surprise;
pub mod table;

pub use diagnostics::{DelayEstimate, Diagnostics, Figure};
pub use error::LearnError;
pub use kind::{LearnerKind, catalogue};
pub use learner::{Decision, Experience, Learner, Table, Truth};
pub use memory::{Memory, MemorySlots};
pub use params::Params;
pub use settings::LearnerSettings;
pub use spec::{LearnerSpec, build};
