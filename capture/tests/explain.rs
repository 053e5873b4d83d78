//! Replay as a search is sound and complete against the model:
//!
//! - complete: a capture the model itself produced, under any schedule of background cycles,
//!   loads, faults, supply dips and resets, with observations hidden at random, is explained
//!   under the readings that produced it;
//! - the explanation is real: its witness, run on the model, reproduces every observation;
//! - sound: a capture with one observation no correct card can show is explained under no
//!   combination of readings at all.

use pmacwd_capture::explain::lanes::{self, LaneDef};
use pmacwd_capture::explain::observe::with_cpu;
use pmacwd_capture::explain::search;
use pmacwd_capture::explain::{report, witness};
use pmacwd_model::controller::Controller;
use pmacwd_specs::check::{ChecksumTarget, Load, ResetEvent, ResetKind};
use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::vocab::command::HostCommand;
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::Spec;
use proptest::prelude::*;
use std::path::PathBuf;

/// One gap of a generated capture: what the model does unseen, and what the host reads after.
#[derive(Clone, Debug)]
struct GapGen {
    cycles: u32,
    /// Chance in percent that a background cycle completes after a servo cycle it may.
    background_percent: u32,
    /// PLC 0 longer than an RTI period for the first cycles of the gap.
    overrun_cycles: u32,
    /// PLC 0 just over an RTI period for the gap's last cycles, background cycles completing
    /// (at `background_percent`) where it leaves them CPU time: it overruns every other RTI.
    overrun_end_cycles: u32,
    fault: Option<ChecksumTarget>,
    /// The supply dips at this cycle of the gap.
    dip_at: Option<u32>,
    /// The card is reset (INIT/) before the gap.
    restart: bool,
    /// Which of `???`, `RHY:$25`, `RHX:$25` the host's reads keep an expectation for.
    observe: [bool; 3],
    seed: u64,
}

fn gap_gen() -> impl Strategy<Value = GapGen> {
    (
        1u32..400,
        prop_oneof![Just(0u32), Just(100), 1u32..100],
        prop_oneof![8 => Just(0u32), 1 => 1u32..12],
        prop_oneof![8 => Just(0u32), 1 => 1u32..24],
        prop_oneof![20 => Just(None), 1 => Just(Some(ChecksumTarget::Firmware)), 1 => Just(Some(ChecksumTarget::UserProgram))],
        prop_oneof![30 => Just(None), 1 => (0u32..400).prop_map(Some)],
        prop_oneof![15 => Just(false), 1 => Just(true)],
        // Y:$25 is read at most polls: a capture that hides it poll after poll leaves the
        // search more than its bound of candidates (refused with exit 2, tested apart).
        (any::<[bool; 3]>(), prop_oneof![4 => Just(true), 1 => Just(false)])
            .prop_map(|(mut o, counter)| {
                o[1] = counter;
                o
            }),
        any::<u64>(),
    )
        .prop_map(|(cycles, background_percent, overrun_cycles, overrun_end_cycles, fault, dip_at, restart, observe, seed)| GapGen {
            cycles,
            background_percent,
            overrun_cycles,
            overrun_end_cycles,
            fault,
            dip_at: dip_at.map(|d| d % cycles),
            restart,
            observe,
            seed,
        })
}

/// A small deterministic random source (the schedule inside a gap).
struct Rng(u64);
impl Rng {
    fn below(&mut self, n: u32) -> u32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 33) % u64::from(n.max(1))) as u32
    }
}

fn spec() -> Spec {
    Spec::embedded().unwrap()
}

/// The lane (search configuration) for the readings with option indices `bits`.
fn lane_for(spec: &Spec, bits: usize) -> (LaneDef, ModelConfig) {
    let defs = lanes::lanes(spec, "host-log", None, false).unwrap();
    let o: [usize; lanes::READINGS_COUNT] = std::array::from_fn(|r| (bits >> r) & 1);
    let def = defs.into_iter().find(|d| d.combinations.contains(&o)).unwrap();
    let cfg = search::Lane::new(spec, "host-log", None, def.clone(), false, None).unwrap().cfg;
    (def, cfg)
}

/// Written under the target directory's scratch space (Cargo's `CARGO_TARGET_TMPDIR`), each name
/// overwritten by the next run: a directory per process under /tmp was never removed (37 of
/// them on this machine).
fn temp_file(name: &str, text: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("explain");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs the gaps on the model and writes what a host would have logged, as JSON Lines. The
/// header says the card's I40 (the model's card has the configuration's): a host log that
/// does not say it leaves I40 the card's own (`explain::unknown`).
fn generate(spec: &Spec, cfg: &ModelConfig, cpu: u8, gaps: &[GapGen]) -> String {
    let header = format!(
        r#"{{"format":"pmacwd-trace","version":1,"description":"generated","configuration":"host-log","card":{{"i40":{}}},"profiles":"all"}}"#,
        cfg.saved.i40
    );
    let mut lines = vec![header];
    let mut card = Controller::power_on(cfg);
    let light = Load { motors: 0, plc0_units: 0, background_units: 1 };
    let heavy = |i8: u8| Load {
        motors: 0,
        plc0_units: (u32::from(cfg.cpu.cycle_units) * (u32::from(i8) + 1) + 1) as u16,
        background_units: 1,
    };
    for g in gaps {
        if g.restart {
            card.apply(
                cfg,
                &Event::Reset(ResetEvent {
                    kind: ResetKind::Init,
                    dpram_fault: false,
                    flash_fault: false,
                    bootstrap: false,
                }),
            );
            lines.push(r#"{"restart":1}"#.into());
        }
        let mut rng = Rng(g.seed);
        if let Some(area) = g.fault {
            card.apply(cfg, &Event::ChecksumFault(area));
        }
        // The background cycle the last command was processed in may end before the next
        // servo cycle, reloading the counter (UM p.236, p.215).
        if card.background_possible() && rng.below(100) < g.background_percent {
            card.background_cycle(cfg);
        }
        for c in 0..g.cycles {
            let overrun_end = g.cycles - c <= g.overrun_end_cycles;
            let load = if c < g.overrun_cycles || overrun_end { heavy(card.i8) } else { light };
            if card.load != load {
                card.apply(cfg, &Event::Load(load));
            }
            if g.dip_at == Some(c) {
                card.apply(cfg, &Event::Supply { millivolts: 4000 });
                card.apply(cfg, &Event::Supply { millivolts: 5000 });
            }
            card.servo_cycle(cfg);
            // While PLC 0 overruns at the start, no background cycle completes (the search's
            // plans do not use CPU time saved from before an overrun for one).
            if c >= g.overrun_cycles && card.background_possible() && rng.below(100) < g.background_percent {
                card.background_cycle(cfg);
            }
        }
        lines.push(format!(r#"{{"elapsed":{}}}"#, g.cycles));
        for (i, cmd) in ["???", "RHY:$25", "RHX:$25"].iter().enumerate() {
            let reply = card.apply(cfg, &Event::Command(HostCommand::parse(cmd).unwrap()));
            let text = match reply {
                Reply::Status { x, y } => {
                    let (x, y) = with_cpu(&pmacwd_specs::config::StatusLayout::of(spec).unwrap(), cpu, (x, y));
                    format!("{x:06X}{y:06X}")
                }
                r => r.to_string(),
            };
            if g.observe[i] {
                lines.push(format!(r#"{{"command":"{cmd}","expect":{{"reply":"{text}"}}}}"#));
            } else {
                lines.push(format!(r#"{{"command":"{cmd}"}}"#));
            }
        }
    }
    lines.join("\n") + "\n"
}

/// 64 cases from a fixed seed, so that CI judges the same captures every run; set
/// `PMACWD_PROPERTY_SEED=<u64>` to explore others (a failure prints its capture).
fn property_config() -> ProptestConfig {
    let seed = std::env::var("PMACWD_PROPERTY_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(14);
    ProptestConfig {
        cases: 64,
        max_shrink_iters: 200,
        failure_persistence: None,
        rng_seed: proptest::test_runner::RngSeed::Fixed(seed),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(property_config())]

    /// Completeness and real explanations: whatever the model did unseen, the search finds a
    /// behaviour under the same readings, and that behaviour reproduces the capture.
    #[test]
    fn every_capture_the_model_produces_is_explained_under_its_readings_by_a_witness_that_reproduces_it(
        bits in 0usize..128,
        cpu in 0u8..4,
        gaps in proptest::collection::vec(gap_gen(), 1..8),
        full_period in proptest::bool::ANY,
    ) {
        let spec = spec();
        // Either detector (strobe_detector, bit 8; issue 36): a full-period card's hardware
        // delay is 90 cycles at 2.25 kHz, not 45 (UM p.215).
        let bits = bits | usize::from(full_period) << 8;
        let (def, cfg) = lane_for(&spec, bits);
        let text = generate(&spec, &cfg, cpu, &gaps);
        let path = temp_file(&format!("complete-{bits}-{cpu}.jsonl"), &text);
        let started = std::time::Instant::now();
        let (lanes, _) = search::search(&spec, &path, Default::default(), vec![def.clone()], false).unwrap();
        if started.elapsed().as_secs_f64() > 1.0 {
            eprintln!("slow case ({:.1} s, peak {} candidates):\n{text}", started.elapsed().as_secs_f64(), lanes[0].peak);
        }
        prop_assert!(lanes[0].death.is_none(), "not explained: {:?}\n{text}", lanes[0].death);
        // The explanation printed is checked on the model before it is called one (how often
        // it reproduces every observation is measured by the rate test below: docs/replay.md).
        let (_, w) = witness::witness_for(&spec, &path, Default::default(), def, lanes[0].tolerances).unwrap();
        prop_assert_eq!(w.checked.clone(), Some(witness::reproduces(&spec, &cfg, &w)));
    }
}

/// How often the search explains, and its witness reproduces, a generated capture, over 300
/// seeded captures of 1 to 7 polls. The property test above needs every capture of its cases
/// explained; over these 300 a few edge cases of the plan families (a run-down or a tail off
/// by one cycle at a parity or RTI-phase boundary) are missed, and a witness is rebuilt from
/// one history per merged candidate and can miss too (then `replay` says so instead of
/// calling it an explanation). The floors below are the rates measured when this test was
/// written, less a margin; docs/replay.md gives the figures and the known misses.
#[test]
fn nearly_every_generated_capture_is_explained_and_its_witness_reproduces_it() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let spec = spec();
    let mut runner = TestRunner::new_with_rng(Config::default(), TestRng::from_seed(RngAlgorithm::ChaCha, &[7; 32]));
    let strategy = (0usize..128, 0u8..4, proptest::collection::vec(gap_gen(), 1..8));
    let (mut explained, mut reproduced, total) = (0, 0, 300);
    for i in 0..total {
        let (bits, cpu, gaps) = strategy.new_tree(&mut runner).unwrap().current();
        let (def, cfg) = lane_for(&spec, bits);
        let text = generate(&spec, &cfg, cpu, &gaps);
        let path = temp_file(&format!("rate-{i}.jsonl"), &text);
        let (lanes, _) = search::search(&spec, &path, Default::default(), vec![def.clone()], false).unwrap();
        if lanes[0].death.is_none() {
            explained += 1;
            let (_, w) = witness::witness_for(&spec, &path, Default::default(), def, lanes[0].tolerances).unwrap();
            if matches!(w.checked, Some(Ok(_))) {
                reproduced += 1;
            } else if std::env::var_os("PMACWD_SHOW_MISSES").is_some() {
                eprintln!("witness of case {i} under {bits} does not reproduce: {:?}\n{text}", w.checked);
            }
        } else if std::env::var_os("PMACWD_SHOW_MISSES").is_some() {
            eprintln!("not explained under {bits}: {:?}\n{text}", lanes[0].death);
        }
        let _ = std::fs::remove_file(&path);
    }
    eprintln!("explained: {explained} of {total}; witnesses reproduced: {reproduced} of {explained}");
    assert!(explained * 100 >= total * EXPLAINED_PERCENT_MIN, "explained: {explained} of {total}");
    assert!(reproduced * 100 >= explained * REPRODUCED_PERCENT_MIN, "reproduced: {reproduced} of {explained}");
}

/// The floors of the test above (measured: see docs/replay.md).
const EXPLAINED_PERCENT_MIN: usize = 99;
const REPRODUCED_PERCENT_MIN: usize = 95;

/// A healthy capture: background cycles often, every observation kept.
fn healthy(spec: &Spec, polls: usize) -> String {
    let (_, cfg) = lane_for(spec, 0b0000010);
    let gaps: Vec<GapGen> = (0..polls)
        .map(|i| GapGen {
            cycles: 200 + i as u32 * 7,
            background_percent: 30,
            overrun_cycles: 0,
            overrun_end_cycles: 0,
            fault: None,
            dip_at: None,
            restart: false,
            observe: [true; 3],
            seed: i as u64,
        })
        .collect();
    generate(spec, &cfg, 0, &gaps)
}

fn explained(spec: &Spec, name: &str, text: &str) -> bool {
    let path = temp_file(name, text);
    report::explain(spec, &path, None).unwrap().explained()
}

/// Replaces the reply of the `n`-th read of `cmd` (1-based) in a generated capture.
fn with_reply(text: &str, cmd: &str, n: usize, reply: &str) -> String {
    let mut seen = 0;
    text.lines()
        .map(|l| {
            if l.contains(&format!(r#""command":"{cmd}""#)) {
                seen += 1;
                if seen == n {
                    return format!(r#"{{"command":"{cmd}","expect":{{"reply":"{reply}"}}}}"#);
                }
            }
            l.to_string()
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

#[test]
fn the_healthy_capture_the_impossible_ones_are_made_from_is_itself_explained() {
    // Otherwise the tests below would prove nothing.
    let spec = spec();
    assert!(explained(&spec, "healthy.jsonl", &healthy(&spec, 6)));
}

#[test]
fn x25_rising_without_a_reset_is_explained_under_no_reading() {
    // SRM p.57: X:$25 is the lowest value since reset; it can only fall.
    let spec = spec();
    let text = with_reply(&healthy(&spec, 6), "RHX:$25", 5, "001000");
    let text = with_reply(&text, "RHX:$25", 3, "000F00");
    assert!(!explained(&spec, "rising.jsonl", &text));
}

#[test]
fn y25_above_the_reload_value_is_explained_under_no_reading() {
    // UM p.215, SRM p.57: the background reloads 4095 or 4096 with I40 = 0; never more.
    let spec = spec();
    let text = with_reply(&healthy(&spec, 6), "RHY:$25", 4, "001001");
    assert!(!explained(&spec, "above.jsonl", &text));
}

#[test]
fn y25_above_4096_is_explained_when_the_capture_does_not_say_i40() {
    // The same capture without `card: {i40: 0}`: the card's I40 is its own (SRM p.57), and a
    // card saved with an I40 at or above 4097 reads Y:$25 = 001001.
    let spec = spec();
    let text = with_reply(&healthy(&spec, 6), "RHY:$25", 4, "001001").replacen(r#""card":{"i40":0},"#, "", 1);
    let path = temp_file("above-open.jsonl", &text);
    let r = report::explain(&spec, &path, None).unwrap();
    let open = r.i40_open.clone().expect("I40 searched");
    assert!(r.explained(), "tried {:?}", open.tried);
    assert!(open.explaining.is_some_and(|v| v >= 4097), "{open:?}");
    assert_eq!(open.highest_read, Some(4097));
}

/// Sets bit 22 of X:$6 in the replies of `???` reads number `from..=to` (1-based).
fn with_bit_22(text: &str, from: usize, to: usize) -> String {
    let mut seen = 0;
    text.lines()
        .map(|l| {
            if l.contains(r#""command":"???""#) {
                seen += 1;
                if (from..=to).contains(&seen) {
                    let reply = l.split(r#""reply":""#).nth(1).unwrap().split('"').next().unwrap();
                    let x = u32::from_str_radix(&reply[..6], 16).unwrap() | 1 << 22;
                    return format!(r#"{{"command":"???","expect":{{"reply":"{x:06X}{}"}}}}"#, &reply[6..]);
                }
            }
            l.to_string()
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

#[test]
fn bit_22_clearing_with_only_reads_and_time_in_between_is_explained_under_no_reading() {
    // SRM p.289: bit 22 stays at 1 until the card is reset or the bit is written to 0.
    let spec = spec();
    let base = healthy(&spec, 6);
    assert!(explained(&spec, "set.jsonl", &with_bit_22(&base, 3, 6)), "an RTI overrun before poll 3 is possible");
    assert!(!explained(&spec, "cleared.jsonl", &with_bit_22(&base, 3, 4)));
}

#[test]
fn a_reply_after_silence_without_a_restart_is_explained_under_no_reading() {
    // UM p.215: a tripped card is latched until power is cycled or INIT/ is pulsed.
    let spec = spec();
    let base = healthy(&spec, 6);
    let silent = with_reply(&base, "???", 3, "(silence)");
    let silent = with_reply(&silent, "RHY:$25", 3, "(silence)");
    let silent = with_reply(&silent, "RHX:$25", 3, "(silence)");
    assert!(!explained(&spec, "silent-then-reply.jsonl", &silent));
    // The same silence with nothing after it is explained: a trip.
    let cut: String = silent.lines().take(1 + 4 * 3).collect::<Vec<_>>().join("\n") + "\n";
    assert!(explained(&spec, "silent-at-end.jsonl", &cut));
}

/// For a property failure: `PMACWD_CAPTURE=file PMACWD_READINGS=bits cargo test --release -p
/// pmacwd-conformance --test explain -- --ignored for_debugging` searches one capture on one lane
/// and prints where it dies.
#[test]
#[ignore]
fn for_debugging_one_capture_is_searched_on_one_lane_and_where_it_dies_is_printed() {
    let spec = spec();
    let path = PathBuf::from(std::env::var("PMACWD_CAPTURE").unwrap());
    let bits: usize = std::env::var("PMACWD_READINGS").unwrap().parse().unwrap();
    let (def, _) = lane_for(&spec, bits);
    let (lanes, _) = search::search(&spec, &path, Default::default(), vec![def], false).unwrap();
    println!("{:?} peak {}", lanes[0].death, lanes[0].peak);
    for c in lanes[0].cands.iter().take(5) {
        println!("Y:$25 {}..={} X:$25 {}..={}", c.counter_lo, c.card.counter, c.min_lo, c.card.counter_min);
    }
    // With PMACWD_WITNESS set: the histories the recording search kept, and the witness.
    if std::env::var_os("PMACWD_WITNESS").is_some() {
        let (lanes, _, _) = search::search_once(
            &spec,
            &path,
            Default::default(),
            std::iter::once((lanes[0].def.clone(), None)),
            true,
            true,
        )
        .unwrap();
        for c in lanes[0].cands.iter().take(3) {
            for n in pmacwd_capture::explain::history::chain(c.node.as_ref().unwrap()) {
                match &n.kind {
                    pmacwd_capture::explain::history::NodeKind::Gap { plan_hi, plan_lo, lo, end } => println!(
                        "  event {}: gap hi {plan_hi:?} lo {plan_lo:?} X:$25 from {lo}, ends Y {} X {}",
                        n.event, end.counter, end.counter_min
                    ),
                    k => println!("  event {}: {k:?}", n.event),
                }
            }
            let (_, w) =
                witness::witness_for(&spec, &path, Default::default(), lanes[0].def.clone(), lanes[0].tolerances)
                    .unwrap();
            println!("witness: {:?}\n{}", w.checked, w.story.join("\n"));
            for (i, (st, _)) in w.collect_steps(&spec).unwrap().iter().enumerate() {
                println!("    step {}: {} {:?}", i + 1, st.event, st.expect.reply);
            }
            println!("---");
        }
    }
}

/// A card whose checksum passes are its own, each area's length apart (UM p.217 gives none; the
/// areas differ in size, and the configuration i40-zero's card takes 2 and 1): with a
/// background cycle after every servo cycle and Y:$25 and X:$25 read after each gap (so that
/// no background cycle can be left out unseen), bit 12's area follows the card's lengths, and
/// the search, stated passes of 1 and 1, must find them.
#[test]
fn a_card_whose_checksum_areas_take_passes_of_their_own_lengths_is_explained() {
    let spec = spec();
    for (firmware, user_program) in [(1u8, 2u8), (2, 1), (2, 2)] {
        let (def, mut cfg) = lane_for(&spec, 0);
        cfg.pass_cycles = pmacwd_specs::check::PassCycles { firmware, user_program };
        let gaps: Vec<GapGen> = [7u32, 11, 5, 13, 9, 10, 6, 8]
            .into_iter()
            .enumerate()
            .map(|(i, cycles)| GapGen {
                cycles,
                background_percent: 100,
                overrun_cycles: 0,
                overrun_end_cycles: 0,
                fault: None,
                dip_at: None,
                restart: false,
                observe: [true; 3],
                seed: i as u64,
            })
            .collect();
        let text = generate(&spec, &cfg, 0, &gaps);
        let path = temp_file(&format!("passes-{firmware}-{user_program}.jsonl"), &text);
        let (lanes, _) = search::search(&spec, &path, Default::default(), vec![def.clone()], false).unwrap();
        assert!(
            lanes[0].death.is_none(),
            "passes {firmware}/{user_program} not explained: {:?}\n{text}",
            lanes[0].death
        );
        assert_eq!(
            lanes[0].tolerances.checksum_pass_cycles, cfg.pass_cycles,
            "passes {firmware}/{user_program}: explained by other lengths\n{text}"
        );
        // The witness names the lengths in its `card:` header and reproduces the capture.
        let (_, w) = witness::witness_for(&spec, &path, Default::default(), def, lanes[0].tolerances).unwrap();
        assert!(matches!(w.checked, Some(Ok(_))), "passes {firmware}/{user_program}: witness {:?}", w.checked);
    }
}

#[test]
fn combinations_whose_hardware_delays_come_out_the_same_are_searched_as_one_lane() {
    // strobe_hz_min and strobe_detector reach the model only through the hardware delay (UM
    // p.215): 50 Hz with a full-period detector asks for the edges 25 Hz with a half-period
    // one does, so of their four pairs three lanes are searched, not four.
    let spec = spec();
    let defs = lanes::lanes(&spec, "host-log", None, false).unwrap();
    let index = |name: &str| lanes::READINGS.iter().position(|(r, _)| *r == name).unwrap();
    let (hz, detector) = (index("strobe_hz_min"), index("strobe_detector"));
    assert_eq!(defs.iter().map(|d| d.combinations.len()).sum::<usize>(), 1 << lanes::READINGS_COUNT);
    // 2^5 for the readings host-log exercises besides the delay (encoder_loss_clear and
    // out_of_range_assignment are not), times the three distinct delays.
    assert_eq!(defs.len(), 32 * 3);
    for d in &defs {
        let pairs: std::collections::BTreeSet<(usize, usize)> =
            d.combinations.iter().map(|c| (c[hz], c[detector])).collect();
        assert!(pairs == [(0, 0), (1, 1)].into() || pairs.len() == 1, "{}: {pairs:?}", lanes::label(&d.choices));
    }
    // A configuration that fixes the delay in cycles searches one lane for all four pairs.
    let fixed = lanes::lanes(&spec, "timing", None, false).unwrap();
    assert_eq!(fixed.len(), 32);
    for d in &fixed {
        let pairs: std::collections::BTreeSet<(usize, usize)> =
            d.combinations.iter().map(|c| (c[hz], c[detector])).collect();
        assert_eq!(pairs.len(), 4, "{}", lanes::label(&d.choices));
    }
}

/// A healthy card polled `polls` times every 0.1 s (`pmacwd_capture::samples`).
fn healthy_polls(polls: u64) -> String {
    let mut out = Vec::new();
    pmacwd_capture::samples::HealthyPolls {
        polls,
        gap_cycles: 225,
        seed: 7,
        profiles: r#"["um-215"]"#,
        description: "SYNTHETIC: a healthy card polled every 0.1 s",
    }
    .write(&mut out)
    .unwrap();
    String::from_utf8(out).unwrap()
}

/// A capture longer than the search's checkpoints are apart: the recorded search lets its
/// history go at them, and the explanation, walked segment by segment (each searched again from
/// the checkpoint before it), still reproduces every observation; every use walks the same
/// steps.
#[test]
fn a_capture_past_the_search_s_checkpoints_is_explained_segment_by_segment_and_reproduced() {
    let spec = Spec::embedded().unwrap();
    let polls = 16_000u64;
    let path = temp_file("past-checkpoints.jsonl", &healthy_polls(polls));
    let def = lanes::lanes(&spec, "host-log", None, false)
        .unwrap()
        .into_iter()
        .find(|d| d.combinations.contains(&lanes::options_of(&spec.profiles.default_profile().choices)))
        .unwrap();
    let (found, events, _) =
        search::search_once(&spec, &path, Default::default(), std::iter::once((def, None)), true, true).unwrap();
    let lane = &found[0];
    assert!(lane.alive(), "{:?}", lane.death);
    assert!(events > 2 * search::CHECKPOINT_EVENTS, "{events} events");
    assert!(lane.checkpoints.len() >= 2, "{} checkpoints over {events} events", lane.checkpoints.len());
    let (_, w, _) = witness::of_lane(&spec, &path, Default::default(), lane, &[]).unwrap();
    // Three replies compared a poll (`???`, Y:$25, X:$25), the card running at each X:$0.
    let checked = w.checked.clone().unwrap().unwrap();
    assert!(checked >= 3 * polls as usize, "{checked} observations checked");
    let steps = w.collect_steps(&spec).unwrap();
    assert_eq!(steps.len(), w.steps);
    assert!(steps.iter().all(|(s, _)| !matches!(s.event, pmacwd_trace::TraceEvent::Elapsed { .. })));
    // The same walk run again under the lane's own readings reproduces it again.
    assert_eq!(witness::reproduces(&spec, &lane.cfg, &w), Ok(checked));
    let r = report::explain(&spec, &path, None).unwrap();
    assert!(r.explained());
    let (_, shown) = r.witness.as_ref().unwrap();
    assert_eq!((shown.steps, shown.checked.clone()), (w.steps, Some(Ok(checked))));
}
