//! What one exchange of a campaign checks: the vocabulary the campaign, the log and the
//! judge share (`campaign.rs` names the checks; `log.rs` writes them beside the exchanges).

/// What an exchange checks, with the manual page that says what a correct card does.
#[derive(Debug, PartialEq, Eq)]
pub struct Check {
    pub id: &'static str,
    pub what: &'static str,
    pub cite: &'static str,
}
