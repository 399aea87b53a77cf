//! Section 4.4 (box and tool-end I/O) and the tool-end Modbus of section
//! 4.14 (4.15 in the V6 document). The I/O itself is [`super::io::Io`];
//! here are the rules: box I/O needs the box connected, tool-end I/O the
//! arm powered, tool Modbus the EtherCAT end I/O (else `Fail,40058`).

use hans_codec::{request as rq, response as rs, CommandId, Decimal};

use super::dispatch::{done, values, Outcome, PARAM};
use super::values::{b, dec, f, hv, idx};
use super::Robot;

/// Tool Modbus on an end I/O that is not the EtherCAT version.
const END_IO_TYPE: i32 = 40058;

/// Outputs to set together: `cdsSetIO`, and each point of `MovePathJOL`.
/// Masks say which outputs change, values their new levels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Outputs {
    /// Tool outputs: mask, levels (bits 0-2).
    pub end_do: (i32, i32),
    /// Box DO: mask, levels (bits 0-7).
    pub box_do: (i32, i32),
    /// Box CO: mask, levels (bits 0-7).
    pub box_co: (i32, i32),
    /// Analog outputs 0 and 1: change (mask), mode, value.
    pub ao: [(bool, i32, f64); 2],
}

impl Outputs {
    /// The twelve values as `cdsSetIO` and `MovePathJOL` send them.
    pub fn from_fields(v: &[Decimal; 12]) -> Outputs {
        let i = |k: usize| {
            v[k].to_i64()
                .and_then(|x| i32::try_from(x).ok())
                .unwrap_or(0)
        };
        Outputs {
            end_do: (i(0), i(1)),
            box_do: (i(2), i(3)),
            box_co: (i(4), i(5)),
            ao: [(i(6) == 1, i(7), f(v[10])), (i(8) == 1, i(9), f(v[11]))],
        }
    }
}

/// Sets the bits of `mask` in `bank` to those of `levels`.
fn set_bits(bank: &mut [bool], (mask, levels): (i32, i32)) {
    for (i, out) in bank.iter_mut().enumerate() {
        if mask >> i & 1 == 1 {
            *out = levels >> i & 1 == 1;
        }
    }
}

impl Robot {
    /// Sets `o`'s outputs now (those the robot cannot reach are skipped:
    /// tool outputs need the arm powered, box outputs the box).
    pub(super) fn apply_outputs(&mut self, o: &Outputs) {
        if self.need_end_io().is_ok() {
            set_bits(&mut self.io.end_do, o.end_do);
        }
        if self.need_box().is_ok() {
            set_bits(&mut self.io.do_, o.box_do);
            set_bits(&mut self.io.co, o.box_co);
            for (ch, &(change, mode, value)) in o.ao.iter().enumerate() {
                if change && matches!(mode, 1 | 2) {
                    self.io.ao_mode[ch] = mode;
                    self.io.ao[ch] = value;
                }
            }
        }
    }

    /// Replies of the V6 document's controllers (from `HR5.50.3`).
    pub(super) fn v6_replies(&self) -> bool {
        self.level >= super::FIRST_V6
    }

    /// From `HR6.3.3` (the revision table) the reply has the 12 V output
    /// too: 8 values instead of 6.
    pub(super) fn read_box_info(&self) -> Outcome<'_> {
        let powered = self.power.is_on() && !self.estop;
        let current = if self.enable.is_on() { 1.2 } else { 0.3 };
        let v12 = CommandId::ReadBoxInfo
            .changed()
            .is_some_and(|at| self.level >= at);
        let on12 = self.box_.is_on() && !self.estop;
        values(rs::ReadBoxInfo {
            connected: b(self.box_.is_on()),
            power_48v: b(powered),
            out_voltage: dec(if powered { 48.0 } else { 0.0 }),
            out_current: dec(if powered { current } else { 0.0 }),
            remote_button: 0,
            three_stage_button: 0,
            voltage_12v: v12.then(|| dec(if on12 { 12.0 } else { 0.0 })),
            current_12v: v12.then(|| dec(if on12 { 0.5 } else { 0.0 })),
        })
    }

    /// The levels of `bits` of one bank of digital I/O.
    fn levels(bank: &[bool], bits: &[i32]) -> Vec<i32> {
        bits.iter().map(|&i| b(bank[idx(i)])).collect()
    }

    pub(super) fn read_box_ci(&self, c: &rq::ReadBoxCI) -> Outcome<'_> {
        self.need_box()?;
        values(rs::ReadBoxCI {
            values: hv(&Self::levels(&self.io.ci, &c.bits)),
        })
    }

    pub(super) fn read_box_di(&self, c: &rq::ReadBoxDI) -> Outcome<'_> {
        self.need_box()?;
        values(rs::ReadBoxDI {
            values: hv(&Self::levels(&self.io.di, &c.bits)),
        })
    }

    pub(super) fn read_box_co(&self, c: &rq::ReadBoxCO) -> Outcome<'_> {
        self.need_box()?;
        values(rs::ReadBoxCO {
            values: hv(&Self::levels(&self.io.co, &c.bits)),
        })
    }

    pub(super) fn read_box_do(&self, c: &rq::ReadBoxDO) -> Outcome<'_> {
        self.need_box()?;
        values(rs::ReadBoxDO {
            values: hv(&Self::levels(&self.io.do_, &c.bits)),
        })
    }

    pub(super) fn read_box_ai(&self, c: &rq::ReadBoxAI) -> Outcome<'_> {
        self.need_box()?;
        let v: Vec<Decimal> = c
            .channels
            .iter()
            .map(|&i| dec(self.io.ai[idx(i)]))
            .collect();
        values(rs::ReadBoxAI { values: hv(&v) })
    }

    /// HR-TCP's controllers reply the value of each channel; the V6
    /// document's the mode and the value of each.
    pub(super) fn read_box_ao(&self, c: &rq::ReadBoxAO) -> Outcome<'_> {
        self.need_box()?;
        let v: Vec<Decimal> = c
            .channels
            .iter()
            .map(|&i| dec(self.io.ao[idx(i)]))
            .collect();
        let modes: Vec<i32> = c
            .channels
            .iter()
            .map(|&i| self.io.ao_mode[idx(i)])
            .collect();
        values(rs::ReadBoxAO {
            values: hv(&v),
            modes: self.v6_replies().then(|| hv(&modes)),
        })
    }

    pub(super) fn set_box_co(&mut self, c: &rq::SetBoxCO) -> Outcome<'_> {
        self.need_box()?;
        self.io.co[idx(c.bit)] = c.value == 1;
        done()
    }

    pub(super) fn set_box_do(&mut self, c: &rq::SetBoxDO) -> Outcome<'_> {
        self.need_box()?;
        self.io.do_[idx(c.bit)] = c.value == 1;
        done()
    }

    pub(super) fn set_box_ao_mode(&mut self, c: &rq::SetBoxAOMode) -> Outcome<'_> {
        self.need_box()?;
        self.io.ao_mode[idx(c.channel)] = c.mode;
        done()
    }

    pub(super) fn set_box_ao(&mut self, c: &rq::SetBoxAO) -> Outcome<'_> {
        self.need_box()?;
        let v = f(c.value);
        let ok = match c.mode {
            1 => (0.0..=10.0).contains(&v),
            _ => (4.0..=20.0).contains(&v),
        };
        if !ok {
            return Err(PARAM);
        }
        let ch = idx(c.channel);
        self.io.ao_mode[ch] = c.mode;
        self.io.ao[ch] = v;
        done()
    }

    pub(super) fn set_end_do(&mut self, c: &rq::SetEndDO) -> Outcome<'_> {
        self.need_end_io()?;
        self.io.end_do[idx(c.bit)] = c.value == 1;
        done()
    }

    pub(super) fn read_ei(&self, c: &rq::ReadEI) -> Outcome<'_> {
        self.need_end_io()?;
        values(rs::ReadEI {
            values: hv(&Self::levels(&self.io.end_di, &c.bits)),
        })
    }

    pub(super) fn read_eo(&self, c: &rq::ReadEO) -> Outcome<'_> {
        self.need_end_io()?;
        values(rs::ReadEO {
            values: hv(&Self::levels(&self.io.end_do, &c.bits)),
        })
    }

    pub(super) fn read_eai(&self, c: &rq::ReadEAI) -> Outcome<'_> {
        self.need_end_io()?;
        values(rs::ReadEAI {
            value: dec(self.io.end_ai[idx(c.channel)]),
        })
    }

    // ------------------------------------------------------ tool Modbus

    /// Tool Modbus needs the arm powered and the EtherCAT end I/O.
    fn need_tool_modbus(&self) -> Result<(), i32> {
        self.need_end_io()?;
        if self.end_io_ethercat {
            Ok(())
        } else {
            Err(END_IO_TYPE)
        }
    }

    pub(super) fn write_holding_registers(&mut self, c: &rq::WriteHoldingRegisters) -> Outcome<'_> {
        self.need_tool_modbus()?;
        let data = c.data.as_slice();
        if !(c.function == 16 || (c.function == 6 && data.len() == 1)) {
            return Err(PARAM);
        }
        let mut words = Vec::with_capacity(data.len());
        for &v in data {
            let v = if (0..=65535).contains(&v) {
                v as u16
            } else if (-32768..0).contains(&v) {
                v as i16 as u16
            } else {
                return Err(PARAM);
            };
            words.push(v);
        }
        let addr = u16::try_from(c.address).map_err(|_| PARAM)?;
        if !self.io.write_registers(idx(c.slave), addr, &words) {
            return Err(PARAM);
        }
        done()
    }

    pub(super) fn read_holding_registers(&self, c: &rq::ReadHoldingRegisters) -> Outcome<'_> {
        self.need_tool_modbus()?;
        if !matches!(c.function, 3 | 4) {
            return Err(PARAM);
        }
        let addr = u16::try_from(c.address).map_err(|_| PARAM)?;
        let words = self
            .io
            .read_registers(idx(c.slave), addr, idx(c.count))
            .ok_or(PARAM)?;
        let v: Vec<i32> = words.iter().map(|&x| i32::from(x)).collect();
        values(rs::ReadHoldingRegisters { values: hv(&v) })
    }

    // ------------------------------------------------ V6 document 4.4, 4.15

    pub(super) fn cds_set_io(&mut self, c: &rq::CdsSetIO) -> Outcome<'_> {
        let o = Outputs {
            end_do: (c.end_do_mask, c.end_do_value),
            box_do: (c.box_do_mask, c.box_do_value),
            box_co: (c.box_co_mask, c.box_co_value),
            ao: [
                (c.ao0_mask == 1, c.ao0_mode, f(c.ao0_value)),
                (c.ao1_mask == 1, c.ao1_mode, f(c.ao1_value)),
            ],
        };
        // "Before the motion reaches its target": at its end; at once when
        // the robot stands still.
        if self.active.is_some() {
            self.pending_outputs = Some(o);
        } else {
            self.apply_outputs(&o);
        }
        done()
    }

    pub(super) fn set_ci_config(&mut self, c: &rq::SetCIConfig) -> Outcome<'_> {
        let trigger = match (c.function, c.trigger) {
            (-1, t) => t.unwrap_or(-1),
            (_, Some(t)) => t,
            (_, None) => return Err(PARAM),
        };
        self.stored.ci_config[idx(c.bit)] = (c.function, trigger);
        done()
    }

    pub(super) fn read_ci_config(&self, c: &rq::ReadCIConfig) -> Outcome<'_> {
        let v: Vec<i32> = match c.bit {
            Some(bit) => {
                let (function, trigger) = self.stored.ci_config[idx(bit)];
                vec![function, if function == -1 { -1 } else { trigger }]
            }
            None => self.stored.ci_config.iter().map(|(f, _)| *f).collect(),
        };
        values(rs::ReadCIConfig { values: hv(&v) })
    }

    pub(super) fn set_end_modbus_info(&mut self, c: &rq::SetEndModbusInfo) -> Outcome<'_> {
        self.need_tool_modbus()?;
        if !matches!(c.parity, 78 | 79 | 69) {
            return Err(PARAM);
        }
        self.stored.end_modbus = [c.baudrate, c.data_bits, c.parity, c.stop_bits];
        done()
    }
}
