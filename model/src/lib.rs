//! # The reference model of the Turbo PMAC watchdog, reset latch and global status
//!
//! Laid out like its sources: [`controller`] is the semantics, rule by rule with citations
//! (UM = Turbo PMAC User Manual, SRM = Software Reference); [`monitor`] and [`properties`] are
//! the checked sentences; [`checker`] is the stateright [`stateright::Model`] with the
//! environment's choices; [`observe`] fills in the vocabulary's observation. Facts, readings
//! and the vocabulary come from `pmacwd-specs` (`pmacwd_specs::config`, `pmacwd_specs::vocab`).
//!
//! ```
//! use pmacwd_model::controller::Controller;
//! use pmacwd_specs::{config::ModelConfig, vocab::{Event, HostCommand, Reply}};
//! let spec = pmacwd_specs::Spec::embedded().unwrap();
//! let profile = spec.profiles.default_profile();
//! let cfg = ModelConfig::from_spec(&spec, "timing", &profile).unwrap();
//! let mut card = Controller::power_on(&cfg);
//! let reply = card.apply(&cfg, &Event::Command(HostCommand::parse("???").unwrap()));
//! assert!(matches!(reply, Reply::Status { .. }));
//! ```

pub mod checker;
pub mod controller;
pub mod ivars;
pub mod monitor;
pub mod motion;
pub mod observe;
pub mod properties;
pub mod show;
pub mod state;
