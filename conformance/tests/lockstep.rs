//! The compact core against the reference model in lockstep: generated event sequences,
//! weighted toward the edges (counter near 0, long idle gaps answered in O(1) by `advance`,
//! RTI overruns, trips and resets, locked I-variables, checksum faults), applied to both under
//! every profile and configuration of the embedded specs, observations compared after every
//! event. proptest shrinks a failure to a minimal sequence and prints it.

use pmacwd_conformance::subject::{CoreSubject, ModelSubject, Subject};
use pmacwd_model::command::HostCommand;
use pmacwd_model::config::ModelConfig;
use pmacwd_model::event::Event;
use pmacwd_specs::check::{ChecksumTarget, ResetEvent, ResetKind};
use pmacwd_specs::Spec;
use proptest::prelude::*;
use std::sync::OnceLock;

/// Every (configuration, profile) of the embedded specs.
fn configs() -> &'static Vec<ModelConfig> {
    static C: OnceLock<Vec<ModelConfig>> = OnceLock::new();
    C.get_or_init(|| {
        let spec = Spec::embedded().unwrap();
        let mut v = Vec::new();
        for name in spec.check.configurations.keys() {
            for p in spec.profiles.all() {
                let mut cfg = ModelConfig::from_spec(&spec, name, &p).unwrap();
                cfg.servo_counter_mask = 0xFF_FFFF;
                v.push(cfg);
            }
        }
        v
    })
}

const COMMANDS: &[&str] = &[
    "???",
    "I130",
    "I130=7",
    "I5100=3",
    "I6800=1",
    "I8000=2",
    "I41=1",
    "I41=3",
    "I41=15",
    "I41=0",
    "I41=16",
    "I40=1",
    "I40=3",
    "I40=0",
    "I8=0",
    "I8=1",
    "I8=3",
    "I8=60",
    "I8=300",
    "RHX:$25",
    "RHY:$25",
    "RHX:$0",
    "RHX:$1080",
    "RHX:$1090",
    "RHX:$6",
    "RHY:$6",
    "OPEN PLC 1",
    "OPEN PROG 1",
    "CLOSE",
    "$$$",
    "HELLO",
];

/// An event choice; `Load` picks among the configuration's loads by index.
#[derive(Clone, Debug)]
enum Choice {
    Event(Event),
    Load(usize),
    Background,
}

fn choice() -> impl Strategy<Value = Choice> {
    prop_oneof![
        6 => (1u32..=4).prop_map(|c| Choice::Event(Event::Servo { cycles: c })),
        2 => (5u32..=200).prop_map(|c| Choice::Event(Event::Servo { cycles: c })),
        1 => (200u32..=20_000).prop_map(|c| Choice::Event(Event::Servo { cycles: c })),
        8 => Just(Choice::Background),
        2 => (0usize..4).prop_map(Choice::Load),
        4 => prop::sample::select(COMMANDS).prop_map(|t| Choice::Event(Event::Command(HostCommand::parse(t).unwrap()))),
        1 => prop::sample::select(&[4500u32, 4750, 5000][..]).prop_map(|mv| Choice::Event(Event::Supply { millivolts: mv })),
        1 => (any::<bool>(), any::<bool>(), any::<bool>(), prop::bool::weighted(0.1)).prop_map(|(power, d, f, b)| Choice::Event(
            Event::Reset(ResetEvent { kind: if power { ResetKind::Power } else { ResetKind::Init }, dpram_fault: d, flash_fault: f, bootstrap: b })
        )),
        1 => prop::sample::select(&[ChecksumTarget::Firmware, ChecksumTarget::UserProgram][..]).prop_map(|a| Choice::Event(Event::ChecksumFault(a))),
        1 => Just(Choice::Event(Event::ClearRtiReentry)),
    ]
}

/// Runs `choices` on both; returns the first disagreement as text.
fn lockstep(cfg: &ModelConfig, choices: &[Choice]) -> Result<(), String> {
    let mut model = ModelSubject::power_on(cfg);
    let mut core = CoreSubject::power_on(cfg);
    let mut history = Vec::new();
    for c in choices {
        let event = match c {
            Choice::Event(e) => e.clone(),
            Choice::Load(i) => Event::Load(cfg.loads[i % cfg.loads.len()]),
            Choice::Background => {
                if model.background_possible() != core.background_possible() {
                    return Err(format!(
                        "background_possible: model {} core {} after {history:?}",
                        model.background_possible(),
                        core.background_possible()
                    ));
                }
                if !model.background_possible() {
                    continue;
                }
                Event::Background
            }
        };
        history.push(event.to_string());
        let (m, k) = (model.apply(&event), core.apply(&event));
        if m != k {
            return Err(format!("after {history:?}\n model {m:?}\n core  {k:?}"));
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, max_shrink_iters: 20_000, ..ProptestConfig::default() })]

    #[test]
    fn the_core_observes_what_the_model_observes_after_every_event(which in 0usize..1000, choices in prop::collection::vec(choice(), 1..300)) {
        let cfgs = configs();
        let cfg = &cfgs[which % cfgs.len()];
        if let Err(e) = lockstep(cfg, &choices) {
            return Err(TestCaseError::fail(format!("{} / {}: {e}", cfg.configuration, cfg.profile.name)));
        }
    }
}

/// `advance(n)` in one event equals n single servo cycles, over long gaps that cross the
/// strobe stop and the trip, for every configuration and profile.
#[test]
fn one_long_servo_event_equals_the_same_cycles_one_by_one() {
    for cfg in configs() {
        for n in [1u32, 2, 3, 5, 7, 45, 46, 100, 4095, 4096, 4097, 4141, 4142, 5000, 10_000] {
            for load in &cfg.loads {
                let mut a = CoreSubject::power_on(cfg);
                let mut b = ModelSubject::power_on(cfg);
                a.apply(&Event::Load(*load));
                b.apply(&Event::Load(*load));
                let one = a.apply(&Event::Servo { cycles: n });
                for _ in 0..n - 1 {
                    b.apply(&Event::Servo { cycles: 1 });
                }
                let many = b.apply(&Event::Servo { cycles: 1 });
                assert_eq!(one, many, "{} / {} load {load:?} n {n}", cfg.configuration, cfg.profile.name);
            }
        }
    }
}
