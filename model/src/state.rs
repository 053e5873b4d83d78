//! A checked state: the controller plus the sticky failures of the transition monitors, and
//! its hash.

use crate::controller::Controller;
use pmacwd_specs::check::ChecksumTarget;

use crate::motion::stop_code;

/// A checked state: the controller plus the sticky failures of the transition monitors.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct State {
    pub controller: Controller,
    /// Bit k set: monitor k of [`MONITORS`] has seen a violating transition.
    pub violations: u64,
}

/// The checker hashes every state it generates (about eight per state it visits) into the
/// fingerprint that identifies it, so the state is fed as seven packed 128-bit words (plus one
/// per written I-variable) instead of field by field: stateright's hasher (aHash) mixes each in
/// one multiply, while a field-by-field hash costs a call per field. Every field goes in, so
/// states that are equal hash equally, as `Hash` requires, and unequal states differ in some
/// word; `hash_feeds_every_field` below checks that.
impl std::hash::Hash for State {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        // Destructured without `..`: a field added to the controller is a compile error here
        // until it is hashed.
        let State { controller, violations } = self;
        let Controller {
            trip,
            supply_low,
            bootstrap,
            counter,
            counter_min,
            cycles_since_strobe,
            rti_phase,
            rti_remaining,
            background_credit,
            load,
            i8,
            i40,
            i41,
            other_i_variables,
            status,
            checksum,
            servo_cycles,
            outputs,
            axes,
            ghost,
        } = controller;
        let crate::controller::Outputs { led_red, fefco_on, relay_tripped, forced_off } = outputs;
        let crate::motion::Axes { motor_slots, motor_count, program_slots, program_count, ghost_healthy_latched_scans } =
            axes;
        let crate::controller::StatusFlags {
            rti_reentry,
            rti_warning,
            servo_error,
            dpram_error,
            flash_error,
            plc_buffer_open,
            motion_buffer_open,
            data_gathering_on,
        } = status;
        let crate::controller::ChecksumEngine {
            area,
            position,
            error,
            firmware,
            firmware_reference,
            program,
            program_reference,
        } = checksum;
        let crate::controller::Ghost { cycles_since_background, last_reload, recovered_by } = ghost;
        let pmacwd_specs::check::Load { motors: motors_load, plc0_units, background_units } = load;
        // Bools by value, not by reference: the compiler then folds them into shifts.
        let flags = [
            *rti_reentry,
            *rti_warning,
            *servo_error,
            *dpram_error,
            *flash_error,
            *plc_buffer_open,
            *motion_buffer_open,
            *data_gathering_on,
            *supply_low,
            *bootstrap,
            *led_red,
            *fefco_on,
            *relay_tripped,
            *forced_off,
        ]
        .into_iter()
        .fold(0u64, |acc, b| acc << 1 | u64::from(b));
        // Each `None` one past its variants, as for the stops (`motion::stop_code`): plain loads.
        let trip = match trip {
            Some(crate::controller::TripCause::Undervoltage) => 0u64,
            Some(crate::controller::TripCause::StrobeTimeout) => 1,
            None => 2,
        };
        let area_code = |a: &ChecksumTarget| match a {
            ChecksumTarget::Firmware => 0u64,
            ChecksumTarget::UserProgram => 1,
        };
        let error_code = error.as_ref().map_or(2, area_code);
        let recovered = match recovered_by {
            Some(pmacwd_specs::check::ResetKind::Init) => 0u64,
            Some(pmacwd_specs::check::ResetKind::Power) => 1,
            None => 2,
        };
        // Motor k is word k: its first seven fields one byte each (the two amplifier-fault bools
        // share the eighth), in the order `Motor` keeps them in
        // memory (`#[repr(C)]`), so the compiler reads several with one load (two motors to a
        // word, packed by bit fields, took 16 instructions a motor; measured with callgrind).
        let mut motors = [0u64; 8];
        for (k, m) in motor_slots.iter().enumerate() {
            let crate::motion::Motor {
                state,
                stop,
                stop_cycles,
                amplifier_enabled,
                output_zero,
                encoder_lost,
                loss_status,
                amplifier_fault,
                fault_status,
            } = m;
            let stop = stop_code(*stop);
            let packed = (*state as u64)
                | stop << 8
                | u64::from(*stop_cycles) << 16
                | u64::from(*amplifier_enabled) << 24
                | u64::from(*output_zero) << 32
                | u64::from(*encoder_lost) << 40
                | u64::from(*loss_status) << 48
                | (u64::from(*amplifier_fault) | u64::from(*fault_status) << 1) << 56;
            motors[k] = packed;
        }
        // Three bits per coordinate system's program, of those that exist: the slots past
        // `program_count` never change (every rule reaches a program through `programs_mut`),
        // so they tell no two states apart.
        let programs =
            program_slots[..usize::from(*program_count)].iter().rev().fold(0u64, |acc, p| acc << 3 | *p as u64);
        let words: [u64; 18] = [
            (*counter as u32 as u64) << 32 | *counter_min as u32 as u64,
            u64::from(*cycles_since_strobe) << 32 | u64::from(*rti_phase) << 16 | u64::from(*i40),
            u64::from(*rti_remaining) << 32 | u64::from(*background_credit),
            u64::from(*motors_load) << 48
                | u64::from(*plc0_units) << 32
                | u64::from(*background_units) << 16
                | u64::from(*motor_count) << 8
                | u64::from(*program_count),
            u64::from(*i8) << 56 | u64::from(*i41) << 48 | flags << 16 | trip << 8 | recovered,
            area_code(area) << 60
                | error_code << 56
                | u64::from(*position) << 48
                | u64::from(*firmware) << 24
                | u64::from(*firmware_reference) << 16
                | u64::from(*program) << 8
                | u64::from(*program_reference),
            u64::from(*servo_cycles) << 8 | u64::from(*ghost_healthy_latched_scans),
            u64::from(*cycles_since_background) << 32 | *last_reload as u32 as u64,
            *violations,
            motors[0],
            motors[1],
            motors[2],
            motors[3],
            motors[4],
            motors[5],
            motors[6],
            motors[7],
            programs,
        ];
        // Two words at a time: aHash mixes a `u128` with a multiply that does not wait for the
        // previous one, while `u64`s form one chain of dependent multiplies (measured: the
        // hash was a fifth of the checker's time, much of it on that chain; 12% after).
        for pair in words.chunks_exact(2) {
            h.write_u128(u128::from(pair[0]) << 64 | u128::from(pair[1]));
        }
        for (n, v) in other_i_variables.iter() {
            h.write_u128(u128::from(*n) << 64 | u128::from(*v as u64));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmacwd_specs::config::ModelConfig;
    use std::hash::{Hash, Hasher};

    fn hash(s: &State) -> u64 {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        s.hash(&mut h);
        h.finish()
    }

    /// Every stop, and no stop, gets its own code in a motor's hash word, within the four bits
    /// the word gives it: two motors that differ only in their stop hash apart.
    #[test]
    fn each_stop_and_no_stop_have_distinct_codes_within_four_bits() {
        use crate::motion::Stop;
        let mut codes: Vec<u64> =
            [Stop::Jog, Stop::Abort, Stop::Quit, Stop::EndOfMove, Stop::Hold].map(|s| stop_code(Some(s))).to_vec();
        codes.push(stop_code(None));
        let distinct: std::collections::BTreeSet<u64> = codes.iter().copied().collect();
        assert_eq!(distinct.len(), codes.len());
        assert!(codes.iter().all(|c| *c < 16));
    }

    /// The packed hash must see every field: change each one alone and the hash must change.
    /// (Equal hashes for unequal states would make the checker skip states it never saw.)
    #[test]
    fn hash_feeds_every_field() {
        let spec = pmacwd_specs::Spec::embedded().unwrap();
        let cfg = ModelConfig::from_spec(&spec, "timing", &spec.profiles.default_profile()).unwrap();
        let base = State { controller: Controller::power_on(&cfg), violations: 0 };
        type Edit = (&'static str, fn(&mut State));
        let edits: Vec<Edit> = vec![
            ("trip", |s| s.controller.trip = Some(crate::controller::TripCause::StrobeTimeout)),
            ("supply_low", |s| s.controller.supply_low = true),
            ("bootstrap", |s| s.controller.bootstrap = true),
            ("counter", |s| s.controller.counter -= 1),
            ("counter_min", |s| s.controller.counter_min -= 1),
            ("cycles_since_strobe", |s| s.controller.cycles_since_strobe += 1),
            ("rti_phase", |s| s.controller.rti_phase += 1),
            ("rti_remaining", |s| s.controller.rti_remaining += 1),
            ("background_credit", |s| s.controller.background_credit += 1),
            ("load.motors", |s| s.controller.load.motors += 1),
            ("load.plc0_units", |s| s.controller.load.plc0_units += 1),
            ("load.background_units", |s| s.controller.load.background_units += 1),
            ("i8", |s| s.controller.i8 += 1),
            ("i40", |s| s.controller.i40 += 1),
            ("i41", |s| s.controller.i41 += 1),
            ("other_i_variables", |s| {
                s.controller.other_i_variables.insert(130, 1);
            }),
            ("rti_reentry", |s| s.controller.status.rti_reentry = true),
            ("rti_warning", |s| s.controller.status.rti_warning = true),
            ("servo_error", |s| s.controller.status.servo_error = true),
            ("dpram_error", |s| s.controller.status.dpram_error = true),
            ("flash_error", |s| s.controller.status.flash_error = true),
            ("plc_buffer_open", |s| s.controller.status.plc_buffer_open = true),
            ("motion_buffer_open", |s| s.controller.status.motion_buffer_open = true),
            ("data_gathering_on", |s| s.controller.status.data_gathering_on = true),
            ("checksum.area", |s| s.controller.checksum.area = ChecksumTarget::UserProgram),
            ("checksum.position", |s| s.controller.checksum.position += 1),
            ("checksum.error", |s| s.controller.checksum.error = Some(ChecksumTarget::Firmware)),
            ("checksum.firmware", |s| s.controller.checksum.firmware ^= 1),
            ("checksum.firmware_reference", |s| s.controller.checksum.firmware_reference ^= 1),
            ("checksum.program", |s| s.controller.checksum.program ^= 1),
            ("checksum.program_reference", |s| s.controller.checksum.program_reference ^= 1),
            ("servo_cycles", |s| s.controller.servo_cycles += 1),
            ("ghost.cycles_since_background", |s| s.controller.ghost.cycles_since_background += 1),
            ("ghost.last_reload", |s| s.controller.ghost.last_reload += 1),
            ("outputs.led_red", |s| s.controller.outputs.led_red = true),
            ("outputs.fefco_on", |s| s.controller.outputs.fefco_on = true),
            ("outputs.relay_tripped", |s| s.controller.outputs.relay_tripped = true),
            ("outputs.forced_off", |s| s.controller.outputs.forced_off = true),
            ("motor.state", |s| s.controller.axes.motor_slots[0].state = pmacwd_specs::vocab::MotorState::Jogging),
            ("motor.stop", |s| s.controller.axes.motor_slots[0].stop = Some(crate::motion::Stop::Hold)),
            // The first stop must not hash as no stop (found by cargo-mutants: `s as u64 + 1`
            // as `s as u64 * 1`); the checker keeps one state per hash, so a collision would
            // merge two states and lose one.
            ("motor.stop = Jog", |s| s.controller.axes.motor_slots[0].stop = Some(crate::motion::Stop::Jog)),
            ("motor.stop_cycles", |s| s.controller.axes.motor_slots[0].stop_cycles = 2),
            ("motor.amplifier_enabled", |s| s.controller.axes.motor_slots[0].amplifier_enabled = true),
            ("motor.output_zero", |s| s.controller.axes.motor_slots[0].output_zero = false),
            ("motor.encoder_lost", |s| s.controller.axes.motor_slots[0].encoder_lost = true),
            ("motor.loss_status", |s| s.controller.axes.motor_slots[0].loss_status = true),
            ("motor 2", |s| s.controller.axes.motor_slots[1].loss_status = true),
            ("programs", |s| s.controller.axes.program_slots[0] = crate::motion::Program::Lost),
            ("axes.motor_count", |s| s.controller.axes.motor_count -= 1),
            ("axes.program_count", |s| s.controller.axes.program_count += 1),
            ("axes.ghost_healthy_latched_scans", |s| s.controller.axes.ghost_healthy_latched_scans = 1),
            ("ghost.recovered_by", |s| s.controller.ghost.recovered_by = Some(pmacwd_specs::check::ResetKind::Init)),
            ("violations", |s| s.violations = 1),
        ];
        for (name, edit) in edits {
            let mut changed = base.clone();
            edit(&mut changed);
            assert_ne!(changed, base, "{name}: the edit must change the state");
            assert_ne!(hash(&changed), hash(&base), "{name} is not hashed");
        }
    }
}
