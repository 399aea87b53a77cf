//! Section 4.4 (box and tool-end I/O) and the tool-end Modbus of section
//! 4.14 (4.15 in the V6 document). The I/O itself is [`super::io::Io`];
//! here are the rules: box I/O needs the box connected, tool-end I/O the
//! arm powered, tool Modbus the EtherCAT end I/O (else `Fail,40058`).

use hans_codec::{request as rq, response as rs, Decimal};

use super::dispatch::{done, values, Outcome, PARAM};
use super::values::{b, dec, f, hv, idx};
use super::Robot;

/// Tool Modbus on an end I/O that is not the EtherCAT version.
const END_IO_TYPE: i32 = 40058;

impl Robot {
    pub(super) fn read_box_info(&self) -> Outcome<'_> {
        let powered = self.power.is_on() && !self.estop;
        let current = if self.enable.is_on() { 1.2 } else { 0.3 };
        values(rs::ReadBoxInfo {
            connected: b(self.box_.is_on()),
            power_48v: b(powered),
            out_voltage: dec(if powered { 48.0 } else { 0.0 }),
            out_current: dec(if powered { current } else { 0.0 }),
            remote_button: 0,
            three_stage_button: 0,
            voltage_12v: None,
            current_12v: None,
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

    pub(super) fn read_box_ao(&self, c: &rq::ReadBoxAO) -> Outcome<'_> {
        self.need_box()?;
        let v: Vec<Decimal> = c
            .channels
            .iter()
            .map(|&i| dec(self.io.ao[idx(i)]))
            .collect();
        values(rs::ReadBoxAO { values: hv(&v) })
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
}
