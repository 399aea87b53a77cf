//! NCMD and DCMD: what a host application writes to the node or the robot.
//!
//! MQTT can see the robot but never move it (the PLC is the one
//! controller): the only write obeyed is `Node Control/Rebirth` = true in
//! an NCMD, which asks for new births. Every other metric of an NCMD, and
//! every metric of a DCMD, is refused and counted; nothing reaches the
//! engine, the queue or the configuration.

use femtopb::Message as _;

use super::proto::{Payload, Value};
use super::topic::MessageType;

/// The one metric a host may write.
pub const REBIRTH: &str = "Node Control/Rebirth";

/// What a command asked, once decoded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CommandSummary {
    /// `Node Control/Rebirth` = true was in an NCMD.
    pub rebirth: bool,
    /// Metric writes refused (saturates).
    pub refused: u16,
}

/// A command payload that is not a Sparkplug B payload (it is dropped;
/// the node counts it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Malformed;

/// Decodes the payload of a command of type `ty` (NCMD or DCMD; any other
/// type is refused whole, as one write) and says what it asks: a pure
/// function, the node applies it ([`super::EdgeNode::command`]).
pub fn decode(ty: MessageType, payload: &[u8]) -> Result<CommandSummary, Malformed> {
    let p = Payload::decode(payload).map_err(|_| Malformed)?;
    let mut out = CommandSummary::default();
    if !matches!(ty, MessageType::NCmd | MessageType::DCmd) {
        out.refused = 1;
        return Ok(out);
    }
    for metric in p.metrics.iter() {
        let metric = metric.map_err(|_| Malformed)?;
        let rebirth = ty == MessageType::NCmd
            && metric.name == Some(REBIRTH)
            && metric.value == Some(Value::Boolean(true));
        if rebirth {
            out.rebirth = true;
        } else {
            out.refused = out.refused.saturating_add(1);
        }
    }
    Ok(out)
}
