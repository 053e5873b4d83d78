//! GATHER and ENDGATHER on the emulator (issue 35): X:$000006 bit 19 "is 1 when the data
//! gathering function is active; it is 0 when the function is not active" (SRM p.289), and
//! gathering runs from GATHER until ENDGATHER (SRM p.307). Before, GATHER was
//! acknowledged while the bit stayed 0.

use pmacwd_emulator::card::{Card, Clock};

/// The first word of a `???` reply, as a number.
fn first_word(card: &mut Card) -> u32 {
    let reply = card.line(b"???").expect("a running card answers");
    let text = String::from_utf8_lossy(&reply);
    let hex: String = text.chars().filter(char::is_ascii_hexdigit).take(6).collect();
    u32::from_str_radix(&hex, 16).unwrap_or_else(|_| panic!("a ??? reply, got {text:?}"))
}

#[test]
fn gather_sets_bit_19_of_the_first_status_word_until_endgather_or_a_reset() {
    const BIT_19: u32 = 1 << 19;
    let mut card = Card::default_card(Clock::Virtual);
    assert_eq!(first_word(&mut card) & BIT_19, 0, "not gathering at power-up");
    for line in ["DEFINE GATHER 1000", "GATHER"] {
        let reply = card.line(line.as_bytes()).expect("answers");
        assert!(!reply.contains(&0x07), "{line} is acknowledged: {reply:?}");
    }
    assert_ne!(first_word(&mut card) & BIT_19, 0, "gathering after GATHER");
    card.line(b"ENDGATHER").expect("answers");
    assert_eq!(first_word(&mut card) & BIT_19, 0, "not gathering after ENDGATHER");
    card.line(b"GAT").expect("answers");
    assert_ne!(first_word(&mut card) & BIT_19, 0, "gathering after GAT");
    card.line(b"$$$").expect("answers");
    assert_eq!(first_word(&mut card) & BIT_19, 0, "a reset ends gathering (MODEL)");
}
