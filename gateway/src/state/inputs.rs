//! What the PLC writes (the inputs of the channels, RAW and the trigger
//! table) and the per-source outputs beside them.

use super::handshake::Handshake;

/// A text area of `N` bytes (ASCII by convention, any byte accepted): as
/// the PLC wrote it, NUL-padded. The text ends at the first NUL.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Text<const N: usize>(pub [u8; N]);

impl<const N: usize> Default for Text<N> {
    fn default() -> Self {
        Text([0; N])
    }
}

impl<const N: usize> core::fmt::Debug for Text<N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "Text({:?})",
            core::str::from_utf8(self.bytes()).unwrap_or("<bytes>")
        )
    }
}

impl<const N: usize> Text<N> {
    /// Empty.
    pub const EMPTY: Self = Text([0; N]);

    /// The text: the bytes up to the first NUL.
    pub fn bytes(&self) -> &[u8] {
        let end = self.0.iter().position(|&b| b == 0).unwrap_or(N);
        self.0.get(..end).unwrap_or(&[])
    }

    /// The text if it is UTF-8 (ASCII), trimmed of blanks.
    pub fn trimmed(&self) -> Option<&str> {
        core::str::from_utf8(self.bytes()).ok().map(str::trim)
    }

    /// `true` when empty.
    pub fn is_empty(&self) -> bool {
        self.0.first().is_none_or(|&b| b == 0)
    }

    /// Replaces the text with `t`, cut to `N` bytes.
    pub fn set(&mut self, t: &[u8]) {
        for (i, slot) in self.0.iter_mut().enumerate() {
            *slot = t.get(i).copied().unwrap_or(0);
        }
    }

    /// Register `i` of the area: two characters, the first in the high byte.
    pub fn word(&self, i: usize) -> u16 {
        let at = |k: usize| u16::from(self.0.get(k).copied().unwrap_or(0));
        (at(2 * i) << 8) | at(2 * i + 1)
    }

    /// Writes register `i` of the area.
    pub fn set_word(&mut self, i: usize, w: u16) {
        let [hi, lo] = w.to_be_bytes();
        if let Some(b) = self.0.get_mut(2 * i) {
            *b = hi;
        }
        if let Some(b) = self.0.get_mut(2 * i + 1) {
            *b = lo;
        }
    }
}

/// Parameters of a channel.
pub const PARAMS: usize = 12;
/// Results of a channel.
pub const RESULTS: usize = 24;

/// The inputs of a command channel, as the PLC wrote them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChannelInputs {
    /// The control register (bit 0 Execute; the other bits are kept).
    pub control: u16,
    /// Command code.
    pub code: u16,
    /// Sequence number.
    pub seq: u16,
    /// The reserved register (kept, unused).
    pub reserved: u16,
    /// P0-P11.
    pub params: [f32; PARAMS],
    /// TEXT1: tool frame name or function name.
    pub text1: Text<32>,
    /// TEXT2: user frame name or function parameters.
    pub text2: Text<32>,
}

impl ChannelInputs {
    /// Execute.
    pub fn execute(&self) -> bool {
        self.control & 1 != 0
    }
}

/// A command channel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ChannelState {
    /// What the PLC wrote.
    pub inputs: ChannelInputs,
    /// The handshake.
    pub handshake: Handshake,
    /// R0-R23 of the last command with results (code 40); `None` (NaN in
    /// the registers) from the rising edge of a command until it gives
    /// results.
    pub results: Option<[f32; RESULTS]>,
}

/// RAW request length in bytes.
pub const RAW_REQUEST: usize = 256;
/// RAW reply room in bytes.
pub const RAW_REPLY: usize = 512;

/// The RAW channel.
#[derive(Clone, Debug, PartialEq)]
pub struct RawState {
    /// The control register (bit 0 Execute).
    pub control: u16,
    /// Sequence number.
    pub seq: u16,
    /// The protocol message to send.
    pub request: Text<RAW_REQUEST>,
    /// The handshake.
    pub handshake: Handshake,
    /// The robot's reply text (cut to [`RAW_REPLY`] bytes).
    pub reply: Text<RAW_REPLY>,
    /// The whole reply's length in characters (also when cut).
    pub reply_len: u16,
}

impl Default for RawState {
    fn default() -> Self {
        RawState {
            control: 0,
            seq: 0,
            request: Text::EMPTY,
            handshake: Handshake::default(),
            reply: Text::EMPTY,
            reply_len: 0,
        }
    }
}

impl RawState {
    /// Execute.
    pub fn execute(&self) -> bool {
        self.control & 1 != 0
    }

    /// The reply was longer than [`RAW_REPLY`] and was cut.
    pub fn reply_truncated(&self) -> bool {
        usize::from(self.reply_len) > RAW_REPLY
    }

    /// Keeps a reply text.
    pub fn set_reply(&mut self, text: &[u8]) {
        self.reply.set(text);
        self.reply_len = u16::try_from(text.len()).unwrap_or(u16::MAX);
    }

    /// Forgets the reply (a new command starts).
    pub fn clear_reply(&mut self) {
        self.reply = Text::EMPTY;
        self.reply_len = 0;
    }
}

pub use crate::job::TRIGGERS;
/// Bytes of a trigger entry's text.
pub const TRIGGER_TEXT: usize = 192;

/// The trigger table: sixteen stored protocol messages, fired by the bits
/// of `TRIG_BITS`.
#[derive(Clone, Debug, PartialEq)]
pub struct Triggers {
    /// `TRIG_BITS` as written: a rising edge of bit `n` fires entry `n`.
    pub bits: u16,
    /// The entries' texts (configuration: saved with it).
    pub entries: [Text<TRIGGER_TEXT>; TRIGGERS],
    /// Each entry's handshake.
    pub handshakes: [Handshake; TRIGGERS],
}

impl Default for Triggers {
    fn default() -> Self {
        Triggers {
            bits: 0,
            entries: [Text::EMPTY; TRIGGERS],
            handshakes: [Handshake::default(); TRIGGERS],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texts_are_registers_of_two_characters() {
        let mut t = Text::<6>::EMPTY;
        t.set(b"ABC");
        assert_eq!((t.word(0), t.word(1), t.word(2)), (0x4142, 0x4300, 0));
        assert_eq!(t.bytes(), b"ABC");
        t.set_word(1, 0x4445);
        assert_eq!(t.bytes(), b"ABDE");
        t.set(b"too long for six");
        assert_eq!(t.bytes(), b"too lo");
        assert!(!t.is_empty() && Text::<4>::EMPTY.is_empty());
    }
}
