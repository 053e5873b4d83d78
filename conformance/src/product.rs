//! Exhaustive lockstep: the model checker explores the product of the reference model and the
//! compact core. Each state is a pair, each action of the model is applied to both, and
//! "the core observes what the model observes" is an `always` property, so every reachable
//! transition of a bounded configuration is exercised on the core, not only random samples.
//! A divergence comes back as the shortest event sequence that reaches it (breadth-first).

use crate::lockstep::{differences, Disagreement};
use pmacwd_bridge::{core_config, core_event, core_observation};
use pmacwd_core as core;
use pmacwd_model::checker::{explored_all, join_observed, Explored, STATES_MAX};
use pmacwd_model::checker::{Action, Leap, State, WatchdogModel};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::event::{Event, Reply};
use stateright::{Checker, Model, Property};
use std::time::{Duration, Instant};

/// How many I-variables besides I8, I40 and I41 the core's store holds in the product. The
/// bounded configurations write a handful; a full store would answer ERR003 and show up as a
/// divergence, never as a silent pass.
pub const STORE_SLOTS: usize = 16;

/// A pair of states, and whether they have parted.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct PairState {
    pub model: State,
    pub core: core::Core,
    pub store: core::FewIVariables<STORE_SLOTS>,
    pub diverged: bool,
}

pub struct ProductModel {
    pub model: WatchdogModel,
    pub core_cfg: core::Config,
}

/// The property's name in reports.
pub const AGREE: &str = "the core observes what the model observes after every event";

impl ProductModel {
    pub fn new(cfg: ModelConfig) -> Self {
        ProductModel { core_cfg: core_config(&cfg), model: WatchdogModel::new(cfg) }
    }

    /// One action on both sides: the concrete event, and the pair after it with what differs.
    pub fn perform(&self, s: &PairState, action: &Action) -> (Event, PairState, Option<Disagreement>) {
        self.pair_after(s, action, self.model.perform(&s.model, action))
    }

    /// [`Self::perform`], with the model's servo cycles of a time jump from `s` taken from
    /// `leap` (simulated into it by the first time jump that needs them): both time jumps of a
    /// state run through the same cycles ([`WatchdogModel::leap`]), so the second one reuses
    /// the first one's. `leap` is `None` or the leap from `s.model`.
    fn perform_sharing(
        &self,
        s: &PairState,
        action: &Action,
        leap: &mut Option<Leap>,
    ) -> (Event, PairState, Option<Disagreement>) {
        let model = match action {
            // What `WatchdogModel::perform` does for a time jump (`advance_to_change`), with
            // the cycles simulated once for both ends.
            Action::ServoToNextChange | Action::ServoToJustBeforeChange => {
                let leap = leap.get_or_insert_with(|| self.model.leap(&s.model));
                let just_before = *action == Action::ServoToJustBeforeChange;
                let (cycles, next) = self.model.end_leap(&s.model, leap, just_before);
                (Event::Servo { cycles }, Reply::None, next)
            }
            Action::Do(_) | Action::Decelerating(..) => self.model.perform(&s.model, action),
        };
        self.pair_after(s, action, model)
    }

    /// The pair after `action` from `s`, given the model's side of it (the event, the reply and
    /// the model's state after it): the core takes the same event, and their observations are
    /// compared.
    fn pair_after(
        &self,
        s: &PairState,
        action: &Action,
        (event, reply, model): (Event, Reply, State),
    ) -> (Event, PairState, Option<Disagreement>) {
        let mut core = s.core;
        let mut store = s.store;
        // The checker explores every deceleration length a stop command can take; the core
        // takes its length from its configuration, so it gets the one the checker chose.
        let core_cfg = match action {
            Action::Decelerating(_, decel) => core::Config {
                motion: core::MotionConfig { decel_cycles: *decel, ..self.core_cfg.motion },
                ..self.core_cfg
            },
            Action::Do(_) | Action::ServoToNextChange | Action::ServoToJustBeforeChange => self.core_cfg,
        };
        let core_reply = core.apply(&core_cfg, core_event(&event), &mut store);
        // Core states that differ only in the lazily kept minimum are one state here
        // (`Core::canonical`), as they were before the core kept it lazily.
        let core = core.canonical(&core_cfg);
        let m = pmacwd_model::observe::of(&model.controller, &self.model.cfg, reply);
        let k = core_observation(&core, &core_cfg, core_reply);
        let mut fields = differences(&m, &k);
        let (bm, bk) = (model.controller.background_possible(), core.background_possible());
        if bm != bk {
            fields.push(format!("background cycle possible: model {bm}, implementation {bk}"));
        }
        let disagreement = (!fields.is_empty()).then(|| Disagreement { event: event.clone(), fields });
        let diverged = disagreement.is_some();
        (event, PairState { model, core, store, diverged }, disagreement)
    }
}

impl Model for ProductModel {
    type State = PairState;
    type Action = Action;

    fn init_states(&self) -> Vec<PairState> {
        let core = core::Core::power_on(&self.core_cfg);
        self.model
            .init_states()
            .into_iter()
            .map(|model| PairState { model, core, store: Default::default(), diverged: false })
            .collect()
    }

    fn actions(&self, s: &PairState, actions: &mut Vec<Action>) {
        if !s.diverged {
            self.model.actions(&s.model, actions);
        }
    }

    fn next_state(&self, s: &PairState, action: Action) -> Option<PairState> {
        Some(self.perform(s, &action).1)
    }

    /// [`Self::next_state`] for each action, except that the two time jumps of a state share
    /// the model's simulated cycles, as the model's own checker does
    /// (`WatchdogModel::for_each_next_state`): each was simulated twice, about 4,000 cycles a
    /// jump in `i40-zero`. Same successors, same order (the test
    /// `the_product_s_leaps_share_their_cycles_and_give_next_state_s_successors`).
    fn for_each_next_state<F>(&self, s: &PairState, actions: &mut Vec<Action>, mut visit: F)
    where
        F: FnMut(&mut Option<PairState>),
    {
        let mut leap: Option<Leap> = None;
        for action in actions.drain(..) {
            let mut next = Some(self.perform_sharing(s, &action, &mut leap).1);
            visit(&mut next);
        }
    }

    fn properties(&self) -> Vec<Property<Self>> {
        vec![Property::always(AGREE, |_, s: &PairState| !s.diverged)]
    }
}

/// The outcome of one exhaustive lockstep run.
#[derive(Clone, Debug)]
pub struct ProductReport {
    pub configuration: String,
    pub profile: String,
    /// Whether every pair state was explored (the checker stops at
    /// [`pmacwd_model::checker::STATES_MAX`]; an incomplete run proves nothing).
    pub complete: bool,
    pub states: usize,
    pub depth: usize,
    pub duration: Duration,
    /// The shortest event sequence to a divergence, and the divergence.
    pub divergence: Option<(Vec<Event>, Disagreement)>,
}

/// Explores the product of the model and the core at `cfg` breadth-first.
pub fn check(cfg: ModelConfig, threads: usize) -> ProductReport {
    check_product(ProductModel::new(cfg), threads)
}

/// As [`check`], telling `progress` how far it has come while it runs
/// ([`pmacwd_model::checker::join_observed`]).
pub fn check_observed(cfg: ModelConfig, threads: usize, progress: &mut dyn FnMut(Explored)) -> ProductReport {
    check_product_observed(ProductModel::new(cfg), threads, progress)
}

/// Explores a product breadth-first (the canary test gives it a deliberately broken model).
pub fn check_product(product: ProductModel, threads: usize) -> ProductReport {
    check_product_observed(product, threads, &mut |_| {})
}

fn check_product_observed(product: ProductModel, threads: usize, progress: &mut dyn FnMut(Explored)) -> ProductReport {
    let cfg = &product.model.cfg;
    let (configuration, profile) = (cfg.configuration.clone(), cfg.profile.name.clone());
    let start = Instant::now();
    let spawned = product.checker().threads(threads).target_state_count(STATES_MAX).spawn_bfs();
    let checker = join_observed(spawned, progress);
    let duration = start.elapsed();
    let product = checker.model();
    let divergence = checker.discovery(AGREE).map(|path| {
        let mut s = product.init_states().remove(0);
        let mut events = Vec::new();
        let mut found = None;
        for a in path.into_actions() {
            let (event, next, d) = product.perform(&s, &a);
            events.push(event);
            s = next;
            if d.is_some() {
                found = d;
                break;
            }
        }
        (events, found.expect("a discovered path ends in a divergence"))
    });
    ProductReport {
        configuration,
        profile,
        complete: explored_all(&checker, STATES_MAX),
        states: checker.unique_state_count(),
        depth: checker.max_depth(),
        duration,
        divergence,
    }
}
