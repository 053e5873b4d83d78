//! The combinations of readings a capture is judged under. Readings are independent
//! dimensions: every combination of their options is a lane, whether or not `profiles.yaml`
//! names it. Options no rule of this capture's configuration reads share a lane, and so do
//! the options of `out_of_range_assignment` for a capture that assigns no I-variable a value
//! outside its range (searched under the default, `error`). `strobe_hz_min` and
//! `strobe_detector` reach the model only through the hardware delay the configuration
//! derives from them (UM p.215; `config::strobe_edge_hz`): combinations whose delays come out
//! the same (25 Hz with a full-period detector, 50 Hz with a half-period one) share a lane.

use pmacwd_specs::config::ModelConfig;
use pmacwd_specs::profiles::*;
use pmacwd_specs::{Spec, SpecError};

/// How many readings there are (the dimensions of a lane).
pub const READINGS_COUNT: usize = 9;

/// Every option of every reading, in the words of `profiles.yaml`. The first option of
/// `out_of_range_assignment` is the default profile's, `error`: a capture that cannot tell the
/// two apart is searched under it.
pub const READINGS: [(&str, [&str; 2]); READINGS_COUNT] = [
    ("reset_value_when_i40_zero", ["4095", "4096"]),
    ("strobe_stop", ["at_zero", "below_zero"]),
    ("strober", ["servo_interrupt", "real_time_interrupt"]),
    ("bit12_meaning", ["prom_checksum_active", "firmware_checksum_error"]),
    ("encoder_loss_clear", ["literal", "intent"]),
    ("strobe_hz_min", ["25", "50"]),
    ("rti_warning_latch", ["level", "sticky"]),
    ("out_of_range_assignment", ["error", "modulo"]),
    ("strobe_detector", ["half_period", "full_period"]),
];

/// The readings the model reads only through the configuration's hardware delay
/// (`ModelConfig::hardware_delay_cycles` and `hardware_delay_band`, UM p.215).
const DELAY_READINGS: [&str; 2] = ["strobe_hz_min", "strobe_detector"];

/// The option index (0 or 1, as in [`READINGS`]) each reading of `c` chooses.
pub fn options_of(c: &Choices) -> [usize; READINGS_COUNT] {
    [
        usize::from(c.reset_value_when_i40_zero == ResetValueWhenI40Zero::R4096),
        usize::from(c.strobe_stop == StrobeStop::BelowZero),
        usize::from(c.strober == Strober::RealTimeInterrupt),
        usize::from(c.bit12_meaning == Bit12Meaning::FirmwareChecksumError),
        usize::from(c.encoder_loss_clear == EncoderLossClear::Intent),
        usize::from(c.strobe_hz_min == StrobeHzMin::Hz50),
        usize::from(c.rti_warning_latch == RtiWarningLatch::Sticky),
        usize::from(c.out_of_range_assignment == OutOfRangeAssignment::Modulo),
        usize::from(c.strobe_detector == StrobeDetector::FullPeriod),
    ]
}

fn choices_of(o: [usize; READINGS_COUNT]) -> Choices {
    Choices {
        reset_value_when_i40_zero: [ResetValueWhenI40Zero::R4095, ResetValueWhenI40Zero::R4096][o[0]],
        strobe_stop: [StrobeStop::AtZero, StrobeStop::BelowZero][o[1]],
        strober: [Strober::ServoInterrupt, Strober::RealTimeInterrupt][o[2]],
        bit12_meaning: [Bit12Meaning::PromChecksumActive, Bit12Meaning::FirmwareChecksumError][o[3]],
        encoder_loss_clear: [EncoderLossClear::Literal, EncoderLossClear::Intent][o[4]],
        strobe_hz_min: [StrobeHzMin::Hz25, StrobeHzMin::Hz50][o[5]],
        rti_warning_latch: [RtiWarningLatch::Level, RtiWarningLatch::Sticky][o[6]],
        out_of_range_assignment: [OutOfRangeAssignment::Error, OutOfRangeAssignment::Modulo][o[7]],
        strobe_detector: [StrobeDetector::HalfPeriod, StrobeDetector::FullPeriod][o[8]],
    }
}

/// Why a reading cannot be judged by a capture in this configuration, if it cannot.
/// `assigns_out_of_range`: whether the capture assigns I8, I40 or I41 a value outside its
/// range ([`assigns_out_of_range`]); without such an assignment both options of
/// `out_of_range_assignment` store the same (UM p.243 rolls over only what lies outside).
pub fn not_exercised(
    spec: &Spec,
    configuration: &str,
    reading: usize,
    assigns_out_of_range: bool,
) -> Option<&'static str> {
    match READINGS[reading].0 {
        "out_of_range_assignment" => (!assigns_out_of_range).then_some(
            "the capture assigns no I-variable the model knows the range of (I8, I40, I41, variables.yaml) a value \
             outside it, which the two options alone tell apart (UM p.243)",
        ),
        "encoder_loss_clear" => Some(
            "replay does not search encoder inputs or motor states yet (the model runs the encoder-loss PLC, but a \
             capture is judged under both readings together)",
        ),
        "strobe_hz_min" | "strobe_detector" => {
            let delays: Vec<_> = (0..4).map(|o| delay_of(spec, configuration, [o & 1, o >> 1])).collect();
            delays
                .iter()
                .all(|d| *d == delays[0])
                .then_some("the configuration fixes the hardware delay in servo cycles")
        }
        _ => None,
    }
}

/// The hardware delay, `(cycles, band)`, of `configuration` under the default profile with
/// the options `o` of `strobe_hz_min` and `strobe_detector` (indices as in [`READINGS`]);
/// None for a configuration that does not resolve (the search reports that itself).
fn delay_of(spec: &Spec, configuration: &str, o: [usize; 2]) -> Option<(u32, (u32, u32))> {
    let mut c = spec.profiles.default_profile().choices;
    c.strobe_hz_min = [StrobeHzMin::Hz25, StrobeHzMin::Hz50][o[0]];
    c.strobe_detector = [StrobeDetector::HalfPeriod, StrobeDetector::FullPeriod][o[1]];
    let p = Profile { name: String::new(), choices: c };
    ModelConfig::from_spec(spec, configuration, &p).map(|cfg| (cfg.hardware_delay_cycles, cfg.hardware_delay_band)).ok()
}

/// One lane: a combination of the readings that matter, with every full combination it
/// stands for.
#[derive(Clone, Debug)]
pub struct LaneDef {
    pub choices: Choices,
    /// The option indices of every combination this lane stands for.
    pub combinations: Vec<[usize; READINGS_COUNT]>,
}

/// The lanes for `configuration`, restricted to the combinations of `profiles` if given.
/// `assigns_out_of_range` as for [`not_exercised`].
pub fn lanes(
    spec: &Spec,
    configuration: &str,
    profiles: Option<&[Profile]>,
    assigns_out_of_range: bool,
) -> Result<Vec<LaneDef>, SpecError> {
    let idle: Vec<bool> =
        (0..READINGS_COUNT).map(|r| not_exercised(spec, configuration, r, assigns_out_of_range).is_some()).collect();
    let delay_readings = DELAY_READINGS.map(|name| READINGS.iter().position(|(r, _)| *r == name).expect("a reading"));
    // The delay each pair of options of the two delay readings gives: a card's servo clock
    // (`with_card`) derives it again from the same edge rate, so pairs that agree here agree
    // for every card.
    let delays: Vec<_> = (0..4).map(|o| delay_of(spec, configuration, [o & 1, o >> 1])).collect();
    // What a lane's search reads: the options of every other reading and the delay.
    let searched = |key: &[usize; READINGS_COUNT]| {
        let mut rest = *key;
        for r in delay_readings {
            rest[r] = 0;
        }
        (rest, delays[key[delay_readings[0]] | key[delay_readings[1]] << 1])
    };
    let mut out: Vec<LaneDef> = Vec::new();
    for bits in 0..1usize << READINGS_COUNT {
        let o: [usize; READINGS_COUNT] = std::array::from_fn(|r| (bits >> r) & 1);
        if let Some(ps) = profiles {
            if !ps.iter().any(|p| options_of(&p.choices) == o) {
                continue;
            }
        }
        let mut key = o;
        for (r, idle) in idle.iter().enumerate() {
            if *idle {
                key[r] = 0;
            }
        }
        let choices = choices_of(key);
        match out.iter_mut().find(|l| searched(&options_of(&l.choices)) == searched(&key)) {
            Some(l) => l.combinations.push(o),
            None => out.push(LaneDef { choices, combinations: vec![o] }),
        }
    }
    Ok(out)
}

/// Whether `command` assigns I8, I40 or I41 a value outside its range (`variables.yaml`,
/// SRM p.42, SRM p.57): the only assignment the two options of `out_of_range_assignment` store
/// differently (the model knows no other variable's range).
pub fn assigns_out_of_range(spec: &Spec, command: &pmacwd_specs::vocab::command::HostCommand) -> bool {
    use pmacwd_specs::vocab::command::HostCommand;
    let vars = &spec.variables.i_variables;
    match *command {
        HostCommand::WriteI(n, v) | HostCommand::WriteIMemory(n, v) => {
            let range = match n {
                8 => &vars.i8.range,
                40 => &vars.i40.range,
                41 => &vars.i41.range,
                _ => return false,
            };
            !(range.min..=range.max).contains(&v)
        }
        _ => false,
    }
}

/// A lane's combination in words: `4096, at_zero, servo_interrupt, ...`.
pub fn label(c: &Choices) -> String {
    options_of(c).iter().enumerate().map(|(r, o)| READINGS[r].1[*o]).collect::<Vec<_>>().join(", ")
}
