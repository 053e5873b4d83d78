//! Synthetic captures of a healthy card, for benchmarks and tests of long logs: the criterion
//! bench's day (`benches/replay.rs`) and the checkpoint test (`tests/explain.rs`).

use std::io::Write;

/// A healthy card polled every `gap_cycles` servo cycles (`RHX:$0`, `???`, `RHY:$25`,
/// `RHX:$25`), as a JSON Lines trace: a background cycle completes every 9 to 13 servo cycles
/// (drawn from `seed`), each flipping the checksum area bit 12 shows; Y:$25 is the counter at
/// the read and X:$25 the lowest since `$$$` (UM p.215, SRM p.57). The CPU type bits are a
/// DSP56321's.
pub struct HealthyPolls<'a> {
    pub polls: u64,
    pub gap_cycles: u32,
    pub seed: u64,
    /// The header's `profiles` value, as JSON (`"all"`, `["um-215"]`).
    pub profiles: &'a str,
    pub description: &'a str,
}

impl HealthyPolls<'_> {
    pub fn write(&self, f: &mut dyn Write) -> std::io::Result<()> {
        let HealthyPolls { polls, gap_cycles, seed, profiles, description } = *self;
        writeln!(
            f,
            r#"{{"format":"pmacwd-trace","version":1,"description":"{description}","configuration":"host-log","profiles":{profiles}}}"#
        )?;
        writeln!(f, r#"{{"command":"$$$"}}"#)?;
        let (r, mut counter, mut lowest, mut area, mut since) = (4096i32, 4096i32, 4096i32, 0u32, 0u32);
        let mut seed = seed;
        for _ in 0..polls {
            for _ in 0..gap_cycles {
                counter -= 1;
                lowest = lowest.min(counter);
                since += 1;
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                if since >= 9 + ((seed >> 33) % 5) as u32 {
                    counter = r;
                    since = 0;
                    area ^= 1;
                }
            }
            writeln!(f, r#"{{"elapsed":{gap_cycles}}}"#)?;
            writeln!(f, r#"{{"command":"RHX:$0"}}"#)?;
            let x = if area == 0 { 0x20_1000 } else { 0x20_0000 };
            writeln!(f, r#"{{"command":"???","expect":{{"reply":"{x:06X}200000"}}}}"#)?;
            writeln!(f, r#"{{"command":"RHY:$25","expect":{{"reply":"{:06X}"}}}}"#, counter & 0xFF_FFFF)?;
            writeln!(f, r#"{{"command":"RHX:$25","expect":{{"reply":"{:06X}"}}}}"#, lowest & 0xFF_FFFF)?;
        }
        Ok(())
    }
}
