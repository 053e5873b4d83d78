//! The conformance suite's view of a controller implementation.
//!
//! Implement [`Subject`] for your emulator, simulator or firmware harness and the lockstep
//! tests, the scenario library and `pmacwd conform` can run against it: the suite powers it up
//! with a configuration resolved from `specs/` (a [`ModelConfig`]), feeds it the events of the
//! model's vocabulary, and compares what it observes with the reference model after every one.
//! [`CoreSubject`] (this project's `no_std` core) is the first implementation; [`ModelSubject`]
//! is the reference itself.

use pmacwd_bridge::{core_config, core_event, core_observation};
use pmacwd_core as core;
use pmacwd_model::controller::Controller;
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::command::{HostCommand, Motion};
use pmacwd_specs::vocab::event::Event;
use pmacwd_specs::vocab::Observation;

/// A controller implementation under test.
pub trait Subject {
    /// Human-readable name for reports.
    fn name(&self) -> &'static str;
    /// Powers up with this configuration (profile readings, CPU costs, saved I-variables).
    fn power_on(cfg: &ModelConfig) -> Self
    where
        Self: Sized;
    /// Whether a background cycle can complete now (the suite only sends `Background` then).
    fn background_possible(&self) -> bool;
    /// Applies one event and reports everything observable afterwards.
    fn apply(&mut self, event: &Event) -> Observation;
}

/// The reference model as a subject.
pub struct ModelSubject {
    cfg: ModelConfig,
    card: Controller,
    /// The last event's stop command (its UM p.217 name) when it met an executing program.
    stop_met_program: Option<&'static str>,
}

impl ModelSubject {
    /// The reference controller as it stands (for coverage and property checks).
    pub fn controller(&self) -> &Controller {
        &self.card
    }

    /// The stop command of the last event, as UM p.217's first column names it, when the card
    /// ran it while a program it stops was executing (its C.S.'s, or any for a global one):
    /// the table's program cases, for the coverage report.
    pub fn stop_met_program(&self) -> Option<&'static str> {
        self.stop_met_program
    }

    fn meets_program(&self, m: Motion) -> bool {
        let programs = self.card.axes.programs();
        let executing = |cs: u8| programs.get(usize::from(cs).wrapping_sub(1)).is_some_and(|p| p.executing());
        match m {
            Motion::Motor(n, _) => n <= self.cfg.motion.motors && executing(self.cfg.motion.coordinate_system(n)),
            Motion::CoordinateSystem(cs, _) => executing(cs),
            Motion::Global(_) => programs.iter().any(|p| p.executing()),
        }
    }
}

impl Subject for ModelSubject {
    fn name(&self) -> &'static str {
        "reference model"
    }
    fn power_on(cfg: &ModelConfig) -> Self {
        ModelSubject { cfg: cfg.clone(), card: Controller::power_on(cfg), stop_met_program: None }
    }
    fn background_possible(&self) -> bool {
        self.card.background_possible()
    }
    fn apply(&mut self, event: &Event) -> Observation {
        self.stop_met_program = match event {
            Event::Command(HostCommand::Motion(m)) if !self.card.tripped() && !self.card.bootstrap => {
                m.stop_table_name().filter(|_| self.meets_program(*m))
            }
            _ => None,
        };
        let reply = self.card.apply(&self.cfg, event);
        pmacwd_model::observe::of(&self.card, &self.cfg, reply)
    }
}

/// This project's compact core as a subject.
pub struct CoreSubject {
    cfg: core::Config,
    core: core::Core,
    /// All 8192 I-variables, as an emulator would embed them (boxed: 64 KiB).
    store: Box<core::AllIVariables>,
}

impl Subject for CoreSubject {
    fn name(&self) -> &'static str {
        "pmacwd-core"
    }
    fn power_on(cfg: &ModelConfig) -> Self {
        let cfg = core_config(cfg);
        CoreSubject { core: core::Core::power_on(&cfg), cfg, store: Box::default() }
    }
    fn background_possible(&self) -> bool {
        self.core.background_possible()
    }
    fn apply(&mut self, event: &Event) -> Observation {
        let reply = self.core.apply(&self.cfg, core_event(event), &mut *self.store);
        core_observation(&self.core, &self.cfg, reply)
    }
}
