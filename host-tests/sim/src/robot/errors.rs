//! `GetErrorCodeStr` (V6 document 4.1.9): the controller's text for an
//! error code. It only ever succeeds.
//!
//! Every code the simulator answers with, or raises as a robot error in
//! tests, has a text: the V6 document's own where it prints one (the
//! codec's [`ErrorCode::text`]), else the simulator's, below. Other codes get
//! the document's `unkown error` (sic: what the controller prints). The
//! client-side codes of the vendor SDKs (39500-39505) are never on the wire,
//! so the controller does not know them either.

use hans_codec::{request as rq, response as rs, ErrorCode, FreeText};

use super::dispatch::{values, Outcome};
use super::Robot;

/// The text of a code the controller does not know.
pub(super) const UNKNOWN_TEXT: &str = "unkown error";

/// Texts for the codes the simulator uses that the document prints none
/// for.
const OWN: &[(i32, &str)] = &[
    (20005, "command not supported"),
    (20016, "point not exist"),
    (20042, "path not ready"),
    (20046, "path calculation error"),
];

/// The controller's text for `code`.
pub(crate) fn error_text(code: i32) -> &'static str {
    if (39500..=39599).contains(&code) {
        return UNKNOWN_TEXT;
    }
    ErrorCode::from(code)
        .text()
        .or_else(|| OWN.iter().find(|(c, _)| *c == code).map(|(_, t)| *t))
        .unwrap_or(UNKNOWN_TEXT)
}

impl Robot {
    pub(super) fn get_error_code_str(&self, c: &rq::GetErrorCodeStr) -> Outcome<'_> {
        values(rs::GetErrorCodeStr {
            text: FreeText::new(error_text(c.code.code())),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_code_the_simulator_uses_has_a_text() {
        for code in [
            10000, 20005, 20006, 20007, 20016, 20018, 20029, 20030, 20042, 20046, 20601, 40014,
            40020, 40058,
        ] {
            assert_ne!(error_text(code), UNKNOWN_TEXT, "{code}");
        }
        assert_eq!(error_text(10000), "Short circuit error");
        assert_eq!(error_text(100), UNKNOWN_TEXT);
        assert_eq!(error_text(39503), UNKNOWN_TEXT);
    }
}
