//! Sparkplug B topics: `spBv1.0/GROUP/TYPE/EDGE[/DEVICE]`.
//!
//! The group, edge node and device ids are bounded strings ([`ID_MAX`]
//! bytes) checked once, when the configuration is made ([`Id::new`]): not
//! empty, and none of the characters the specification forbids in them
//! (`/`, `+`, `#`). A topic is then at most [`TOPIC_MAX`] bytes, so writing
//! one cannot fail.

use core::fmt::Write as _;

/// The namespace of Sparkplug B.
pub const NAMESPACE: &str = "spBv1.0";

/// Bytes of a group, edge node or device id, at most.
pub const ID_MAX: usize = 32;

/// Bytes of a topic, at most: the namespace, three ids, a type, slashes.
pub const TOPIC_MAX: usize = NAMESPACE.len() + 3 * ID_MAX + "NBIRTH".len() + 4;

/// A topic.
pub type Topic = heapless::String<TOPIC_MAX>;

/// Why an id was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IdError {
    /// It is empty.
    Empty,
    /// It is longer than [`ID_MAX`] bytes.
    TooLong,
    /// It contains `/`, `+` or `#` (the character).
    Forbidden(char),
}

/// A group, edge node or device id.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Id(heapless::String<ID_MAX>);

impl Id {
    /// Checks `s`.
    pub fn new(s: &str) -> Result<Id, IdError> {
        if s.is_empty() {
            return Err(IdError::Empty);
        }
        if let Some(c) = s.chars().find(|c| matches!(c, '/' | '+' | '#')) {
            return Err(IdError::Forbidden(c));
        }
        let mut out = heapless::String::new();
        out.push_str(s).map_err(|_| IdError::TooLong)?;
        Ok(Id(out))
    }

    /// The id.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

/// The message types (the topic's third element).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MessageType {
    /// The node's birth certificate.
    NBirth,
    /// The node's death certificate (the MQTT Will).
    NDeath,
    /// The node's data.
    NData,
    /// A command to the node.
    NCmd,
    /// The device's birth certificate.
    DBirth,
    /// The device's death certificate.
    DDeath,
    /// The device's data.
    DData,
    /// A command to the device.
    DCmd,
}

impl MessageType {
    /// As in the topic.
    pub const fn as_str(self) -> &'static str {
        match self {
            MessageType::NBirth => "NBIRTH",
            MessageType::NDeath => "NDEATH",
            MessageType::NData => "NDATA",
            MessageType::NCmd => "NCMD",
            MessageType::DBirth => "DBIRTH",
            MessageType::DDeath => "DDEATH",
            MessageType::DData => "DDATA",
            MessageType::DCmd => "DCMD",
        }
    }

    /// The topic names the device.
    pub const fn is_device(self) -> bool {
        matches!(
            self,
            MessageType::DBirth | MessageType::DDeath | MessageType::DData | MessageType::DCmd
        )
    }

    /// The MQTT QoS to publish with: 1 for the NDEATH Will, 0 for every
    /// other message. None is retained.
    pub const fn qos(self) -> u8 {
        match self {
            MessageType::NDeath => 1,
            _ => 0,
        }
    }
}

/// The topic of `ty` for node `edge` of `group` (and `device` for device
/// messages).
pub fn topic(group: &Id, edge: &Id, device: &Id, ty: MessageType) -> Topic {
    let mut t = Topic::new();
    // Cannot fail: every part is bounded and TOPIC_MAX adds them up.
    let _ = write!(
        t,
        "{NAMESPACE}/{}/{}/{}",
        group.as_str(),
        ty.as_str(),
        edge.as_str()
    );
    if ty.is_device() {
        let _ = write!(t, "/{}", device.as_str());
    }
    t
}

/// What an incoming topic is for this node: its NCMD, its device's DCMD,
/// or nothing (`None`: another node's, another type, not Sparkplug).
pub fn inbound(group: &Id, edge: &Id, device: &Id, topic: &str) -> Option<MessageType> {
    let mut parts = topic.split('/');
    let ns = parts.next()?;
    let g = parts.next()?;
    let ty = parts.next()?;
    let e = parts.next()?;
    let d = parts.next();
    if ns != NAMESPACE || g != group.as_str() || e != edge.as_str() || parts.next().is_some() {
        return None;
    }
    match (ty, d) {
        ("NCMD", None) => Some(MessageType::NCmd),
        ("DCMD", Some(d)) if d == device.as_str() => Some(MessageType::DCmd),
        _ => None,
    }
}
