//! Citations: every fact in `specs/` says where it comes from.
//!
//! A citation is a source token, then a page for the manuals:
//!
//! | token | source | page |
//! |---|---|---|
//! | `UM` | Turbo PMAC User Manual | required: `UM p.215`, `UM p.289-290` |
//! | `SRM` | Turbo PMAC/PMAC2 Software Reference | required |
//! | `PMAC-SRM` | the older (non-Turbo) PMAC Software Reference | required |
//! | `PMAC-UM` | the older (non-Turbo) PMAC User Manual | optional |
//! | `BRICK-HRM` | Geo Brick hardware reference manual | optional |
//! | `M-FILE` | Delta Tau suggested M-variable definitions file | none |
//! | `GlobalStatus.py` | DLS dls-pmac-control transcription of the SRM status bits ("T") | none |
//! | `DLS-PMACCONTROL` | DLS's Qt GUI dls-pmaccontrol 3.2.3 (what it sends and how it reads the answers) | none |
//! | `EPICS-PMAC` | DiamondLightSource/pmac `pmacHardwareTurbo.cpp` | none |
//! | `DLS-PMACLIB` | the dls-pmaclib client library | none |
//! | `TPMAC` | epics-modules/tpmac | none |
//! | `FACTS` | `shared/reference/turbo-pmac-facts.md`, by section (`FACTS s.6`) | optional |
//! | `MODEL` | a choice this project made where the sources say nothing; states its reason | none |
//!
//! After the page (or the token) a free-text locator in double quotes may follow:
//! `UM p.240 "Background Cycle Time"`.

use serde::de::Error as _;
use serde::{Deserialize, Deserializer};
use std::fmt;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Source {
    Um,
    Srm,
    PmacSrm,
    PmacUm,
    BrickHrm,
    MFile,
    GlobalStatusPy,
    DlsPmaccontrol,
    EpicsPmac,
    DlsPmaclib,
    Tpmac,
    Facts,
    Model,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum PageRule {
    Required,
    Optional,
    None,
}

impl Source {
    const ALL: [(Source, &'static str, PageRule); 13] = [
        (Source::Um, "UM", PageRule::Required),
        (Source::Srm, "SRM", PageRule::Required),
        (Source::PmacSrm, "PMAC-SRM", PageRule::Required),
        (Source::PmacUm, "PMAC-UM", PageRule::Optional),
        (Source::BrickHrm, "BRICK-HRM", PageRule::Optional),
        (Source::MFile, "M-FILE", PageRule::None),
        (Source::GlobalStatusPy, "GlobalStatus.py", PageRule::None),
        (Source::DlsPmaccontrol, "DLS-PMACCONTROL", PageRule::None),
        (Source::EpicsPmac, "EPICS-PMAC", PageRule::None),
        (Source::DlsPmaclib, "DLS-PMACLIB", PageRule::None),
        (Source::Tpmac, "TPMAC", PageRule::None),
        (Source::Facts, "FACTS", PageRule::Optional),
        (Source::Model, "MODEL", PageRule::None),
    ];

    pub fn token(self) -> &'static str {
        Self::ALL.iter().find(|(s, ..)| *s == self).map(|(_, t, _)| *t).unwrap_or("?")
    }
}

/// One parsed citation, e.g. `UM p.215`.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Cite {
    pub source: Source,
    /// `215`, `289-290`, or a section such as `s.6` for FACTS.
    pub page: Option<String>,
    pub locator: Option<String>,
}

impl Cite {
    pub fn parse(text: &str) -> Result<Cite, String> {
        let text = text.trim();
        let (head, locator) = match text.find('"') {
            Some(i) => {
                let rest = &text[i..];
                if rest.len() < 2 || !rest.ends_with('"') {
                    return Err(format!("citation `{text}`: a locator is one double-quoted text at the end"));
                }
                (text[..i].trim_end(), Some(rest[1..rest.len() - 1].to_string()))
            }
            None => (text, None),
        };
        let mut words = head.split_whitespace();
        let token = words.next().ok_or_else(|| "empty citation".to_string())?;
        let Some((source, _, rule)) = Source::ALL.iter().find(|(_, t, _)| *t == token) else {
            let known: Vec<&str> = Source::ALL.iter().map(|(_, t, _)| *t).collect();
            return Err(format!("citation `{text}`: unknown source `{token}` (known: {})", known.join(", ")));
        };
        let page = match words.next() {
            Some(p) => {
                let p = p
                    .strip_prefix("p.")
                    .or_else(|| if *source == Source::Facts { p.strip_prefix("s.").map(|_| p) } else { None })
                    .ok_or_else(|| format!("citation `{text}`: expected `p.N` after `{token}`"))?;
                let ok = !p.is_empty()
                    && p.split('-').count() <= 2
                    && p.split('-')
                        .all(|n| !n.is_empty() && n.chars().all(|c| c.is_ascii_digit() || c == '.' || c == 's'));
                if !ok {
                    return Err(format!("citation `{text}`: page `{p}` is not a number or range"));
                }
                Some(p.to_string())
            }
            None => None,
        };
        if let Some(extra) = words.next() {
            return Err(format!("citation `{text}`: unexpected `{extra}` (quote free text)"));
        }
        match (rule, &page) {
            (PageRule::Required, None) => {
                Err(format!("citation `{text}`: `{token}` needs a page, e.g. `{token} p.215`"))
            }
            (PageRule::None, Some(_)) => Err(format!("citation `{text}`: `{token}` has no pages")),
            _ => Ok(Cite { source: *source, page, locator }),
        }
    }
}

impl fmt::Display for Cite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.source.token())?;
        if let Some(p) = &self.page {
            // Only FACTS reads a bare `s.N`; any other source wrote `p.s.57` and reads only that.
            if self.source == Source::Facts && p.starts_with("s.") {
                write!(f, " {p}")?;
            } else {
                write!(f, " p.{p}")?;
            }
        }
        if let Some(l) = &self.locator {
            write!(f, " \"{l}\"")?;
        }
        Ok(())
    }
}

/// One citation or a non-empty list of them: `cite: UM p.215` or `cite: [UM p.215, SRM p.57]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cites(pub Vec<Cite>);

impl fmt::Display for Cites {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, c) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str("; ")?;
            }
            write!(f, "{c}")?;
        }
        Ok(())
    }
}

impl<'de> Deserialize<'de> for Cites {
    /// A visitor rather than an untagged enum: untagged buffering loses the position, and a
    /// bad citation should be reported where it is written.
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = Cites;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a citation such as `UM p.215`, or a list of them")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Cites, E> {
                Cite::parse(v).map(|c| Cites(vec![c])).map_err(E::custom)
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Cites, A::Error> {
                let mut cites = Vec::new();
                while let Some(text) = seq.next_element::<String>()? {
                    cites.push(Cite::parse(&text).map_err(A::Error::custom)?);
                }
                if cites.is_empty() {
                    return Err(A::Error::custom("`cite` must name at least one source"));
                }
                Ok(Cites(cites))
            }
        }
        d.deserialize_any(Visitor)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manual_citations_need_a_page_and_print_back_unchanged() {
        for text in ["UM p.215", "SRM p.289-290", "UM p.240 \"Background Cycle Time\"", "FACTS s.6", "M-FILE"] {
            assert_eq!(Cite::parse(text).unwrap().to_string(), text);
        }
        assert!(Cite::parse("UM").unwrap_err().contains("needs a page"));
        assert!(Cite::parse("UM 215").unwrap_err().contains("expected `p.N`"));
        assert!(Cite::parse("Manual p.3").unwrap_err().contains("unknown source"));
        assert!(Cite::parse("M-FILE p.3").unwrap_err().contains("has no pages"));
    }

    #[test]
    fn a_page_that_starts_with_s_prints_back_as_a_citation_that_parses() {
        // Found by the fuzz target yaml_trace: `SRM p.s.57` was accepted and printed as
        // `SRM s.57`, which only FACTS reads, so a trace with it did not read back.
        for text in ["SRM p.s.57", "UM p.s.1-s.2", "FACTS s.6", "FACTS p.s.6", "FACTS p.6"] {
            let cite = Cite::parse(text).unwrap();
            assert_eq!(Cite::parse(&cite.to_string()), Ok(cite.clone()), "{text} prints as {cite}");
        }
        assert_eq!(Cite::parse("SRM p.s.57").unwrap().to_string(), "SRM p.s.57");
    }
}
