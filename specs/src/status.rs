//! `status.yaml`: the 48 bits of the `???` reply and the reply's shape.

use crate::cite::Cites;
use crate::yaml::SourceMap;
use crate::SpecError;
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap};

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Status {
    pub reply: ReplyShape,
    pub words: Words,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReplyShape {
    /// Hex characters in a normal reply (12).
    pub characters: u8,
    pub layout: String,
    pub bootstrap_reply: String,
    pub cite: Cites,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Words {
    #[serde(rename = "X")]
    pub x: Word,
    #[serde(rename = "Y")]
    pub y: Word,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Word {
    /// `X:$000006` or `Y:$000006`.
    pub address: String,
    /// Which part of the reply: `first` or `second`.
    pub reply_position: String,
    pub bits: BTreeMap<u8, StatusBit>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StatusBit {
    /// snake_case name, unique over both words; code refers to bits by it.
    pub name: String,
    pub meaning: String,
    pub set_by: String,
    pub cleared_by: String,
    pub latch: Latch,
    pub cite: Cites,
}

/// How a bit holds its value.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Latch {
    /// Stays set until reset or an explicit clear.
    Sticky,
    /// Follows a condition.
    Level,
    /// Fixed by the hardware configuration.
    Static,
    /// Reserved or internal; the manuals do not say.
    Unknown,
}

/// Which of the two status words.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum WordId {
    X,
    Y,
}

impl Status {
    pub(crate) fn validate(&self, map: &SourceMap) -> Result<(), SpecError> {
        if self.reply.characters != 12 {
            return Err(map.error("reply.characters", "the ??? reply has 12 hex characters (SRM p.289)"));
        }
        for (id, word) in [("X", &self.words.x), ("Y", &self.words.y)] {
            for bit in word.bits.keys() {
                if *bit > 23 {
                    return Err(map.error(
                        &format!("words.{id}.bits.{bit}"),
                        format!("a status word has bits 0..=23; there is no bit {bit}"),
                    ));
                }
            }
            if word.bits.len() != 24 {
                let missing: Vec<String> =
                    (0..24u8).filter(|b| !word.bits.contains_key(b)).map(|b| b.to_string()).collect();
                return Err(map.error(
                    &format!("words.{id}.bits"),
                    format!("word {id} must list all 24 bits; missing: {}", missing.join(", ")),
                ));
            }
        }
        // Names are checked in file order, so a duplicate is reported where it is written second.
        let mut paths: Vec<String> = [("X", &self.words.x), ("Y", &self.words.y)]
            .iter()
            .flat_map(|(id, word)| word.bits.keys().map(move |b| format!("words.{id}.bits.{b}")))
            .collect();
        map.sort_by_position(&mut paths);
        let mut names: HashMap<&str, &str> = HashMap::new();
        for path in &paths {
            let entry = self.entry_at(path).expect("path built from the entries");
            if !crate::common::is_identifier(&entry.name) {
                return Err(map.error(&format!("{path}.name"), format!("`{}` is not a snake_case name", entry.name)));
            }
            if let Some(first) = names.insert(&entry.name, path) {
                return Err(map.error(
                    &format!("{path}.name"),
                    format!("status bit name `{}` is already used by {first}", entry.name),
                ));
            }
        }
        Ok(())
    }

    fn entry_at(&self, path: &str) -> Option<&StatusBit> {
        let mut parts = path.split('.').skip(1);
        let word = match parts.next()? {
            "X" => WordId::X,
            _ => WordId::Y,
        };
        let bit = parts.nth(1)?.parse().ok()?;
        self.entry(word, bit)
    }

    /// Word and bit number of the bit called `name`.
    pub fn bit(&self, name: &str) -> Option<(WordId, u8)> {
        for (id, word) in [(WordId::X, &self.words.x), (WordId::Y, &self.words.y)] {
            if let Some((b, _)) = word.bits.iter().find(|(_, e)| e.name == name) {
                return Some((id, *b));
            }
        }
        None
    }

    pub fn entry(&self, word: WordId, bit: u8) -> Option<&StatusBit> {
        match word {
            WordId::X => self.words.x.bits.get(&bit),
            WordId::Y => self.words.y.bits.get(&bit),
        }
    }
}
