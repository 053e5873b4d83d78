//! The emulator and the model agree on ack versus error for every line (issue 28): both read
//! it with the one grammar (`pmacwd_specs::grammar`), and a line the card refuses somewhere is
//! one the model refuses too. Lines are generated from the forms host programs send, the
//! manual's examples and text no card reads, run together or spaced.
//!
//! Left out on purpose, each a documented difference: writes of I3 or I6 outside 0..3 (the
//! emulator refuses them to keep its framing, MODEL, `framing::FRAMING_VALUE_MAX`), and `OPEN`
//! (the rest of its line is program text for the card).

use pmacwd_emulator::card::{Card, Clock};
use pmacwd_model::controller::Controller;
use pmacwd_specs::grammar::{pieces, Addressing};
use pmacwd_specs::vocab::event::{Event, Reply};
use pmacwd_specs::vocab::HostCommand;
use proptest::prelude::*;

const FRAGMENTS: &[&str] = &[
    "???",
    "&1??",
    "#1?",
    "#2P",
    "V",
    "F",
    "I130",
    "I130=7",
    "I130,4,100",
    "I20..23",
    "I130=1.25*I130",
    "I222=0.5",
    "I130=*",
    "I40=*",
    "I41=1",
    "I41=0",
    "I5100=3",
    "I(100+30)",
    "I(P1+130)=5",
    "P1=5",
    "P1",
    "Q71=Q81",
    "&2Q81",
    "M162=1000/0.0009765625",
    "M162",
    "M100->X:$25,0,24,S",
    "M100",
    "M1..3->",
    "WX:$2082,7",
    "RHX:$25",
    "RHY:$25",
    "RHX:$0",
    "RHX:$78F00",
    "CHKS",
    "$$$",
    "CPU",
    "CID",
    "VER",
    "&1#1->",
    "&1#1->,",
    "#1->1000X",
    "UNDEFINE ALL",
    "&1%100.000000",
    "&1%",
    "%0",
    "#1J+",
    "#1J/",
    "#1J=100",
    "#1J^-5",
    "#1HM",
    "#1HMZ",
    "#1K",
    "&1A",
    "&1B1R",
    "&1B10R",
    "&1E",
    "&1S",
    "LIST PLC 1,0,2",
    "&1Q",
    "&1H",
    "\x0b",
    "\x01",
    "ENABLE PLC 1",
    "LIST PROG 1",
    "DEFINE GATHER",
    "GATHER",
    "ENDG",
    "SAVE",
    "MS0,I910",
    "ZZZ",
    "I8192",
    "#33K",
    "I40=abc",
    "&17A",
    "I5=",
    "$$$**",
    "\x02",
];

fn line() -> impl Strategy<Value = String> {
    (prop::collection::vec(prop::sample::select(FRAGMENTS), 1..6), prop::collection::vec(any::<bool>(), 6)).prop_map(
        |(parts, spaced)| {
            let mut s = String::new();
            for (k, p) in parts.iter().enumerate() {
                if k > 0 && spaced[k] {
                    s.push(' ');
                }
                s.push_str(p);
            }
            s
        },
    )
}

/// Whether the model refuses some command of `line`; `None` when the line holds a command
/// the model cannot follow (it does not say what the card holds).
fn model_refuses(cfg: &pmacwd_specs::config::ModelConfig, card: &mut Controller, line: &str) -> Option<bool> {
    for p in pieces(line.as_bytes(), &mut Addressing::default()) {
        let Ok(c) = p.command else { return Some(true) };
        let h = HostCommand::from_grammar(&c).ok()?;
        if let Reply::Error(_) = card.apply(cfg, &Event::Command(h)) {
            return Some(true);
        }
    }
    Some(false)
}

/// The emulator's configuration (`Card::default_card`), read once.
fn config() -> &'static pmacwd_specs::config::ModelConfig {
    static CFG: std::sync::OnceLock<pmacwd_specs::config::ModelConfig> = std::sync::OnceLock::new();
    CFG.get_or_init(|| {
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        pmacwd_specs::config::ModelConfig::from_spec(&spec, "i40-zero", &spec.profiles.default_profile()).unwrap()
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    #[test]
    fn the_emulator_and_the_model_refuse_the_same_lines(lines in prop::collection::vec(line(), 1..4)) {
        let cfg = config();
        let mut model = Controller::power_on(cfg);
        let mut card = Card::default_card(Clock::Virtual);
        for line in &lines {
            let Some(refused) = model_refuses(cfg, &mut model, line) else { return Ok(()) };
            let reply = card.line(line.as_bytes()).expect("a running card answers");
            let emulator_refused = reply.contains(&0x07);
            prop_assert_eq!(emulator_refused, refused, "line `{}`: the emulator answered {:?}", line.escape_debug(), String::from_utf8_lossy(&reply));
        }
    }
}
