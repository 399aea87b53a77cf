//! The controller's I/O: electric-box digital and analog I/O, tool-end I/O
//! and the holding registers of the tool-flange Modbus slave.

use std::collections::BTreeMap;

/// Most registers stored per tool-flange slave; writes to new addresses
/// beyond that are refused (`Fail,20006`).
pub const MAX_REGISTERS: usize = 4096;

/// A snapshot of all I/O (also what `Sim::io()` returns).
#[derive(Clone, Debug, PartialEq)]
pub struct Io {
    /// Box control inputs CI0-CI7.
    pub ci: [bool; 8],
    /// Box control outputs CO0-CO7.
    pub co: [bool; 8],
    /// Box general inputs DI0-DI7.
    pub di: [bool; 8],
    /// Box general outputs DO0-DO7.
    pub do_: [bool; 8],
    /// Box analog inputs (V or mA).
    pub ai: [f64; 2],
    /// Box analog outputs (V or mA).
    pub ao: [f64; 2],
    /// Box analog output modes: 0 off, 1 voltage, 2 current.
    pub ao_mode: [i32; 2],
    /// Tool-end digital inputs.
    pub end_di: [bool; 4],
    /// Tool-end digital outputs.
    pub end_do: [bool; 4],
    /// Tool-end analog inputs.
    pub end_ai: [f64; 2],
    /// Tool-end buttons.
    pub end_button: [bool; 4],
    /// Holding registers of tool-flange Modbus slaves 0 and 1
    /// (unwritten registers read 0).
    pub registers: [BTreeMap<u16, u16>; 2],
}

impl Default for Io {
    fn default() -> Self {
        Io {
            ci: [false; 8],
            co: [false; 8],
            di: [false; 8],
            do_: [false; 8],
            ai: [0.0; 2],
            ao: [0.0; 2],
            ao_mode: [1; 2],
            end_di: [false; 4],
            end_do: [false; 4],
            end_ai: [0.0; 2],
            end_button: [false; 4],
            registers: [BTreeMap::new(), BTreeMap::new()],
        }
    }
}

impl Io {
    /// Reads `count` registers of `slave` from `addr`.
    pub fn read_registers(&self, slave: usize, addr: u16, count: usize) -> Option<Vec<u16>> {
        let regs = self.registers.get(slave)?;
        (0..count)
            .map(|i| {
                let a = u16::try_from(usize::from(addr) + i).ok()?;
                Some(regs.get(&a).copied().unwrap_or(0))
            })
            .collect()
    }

    /// Writes registers of `slave` from `addr`; `false` (nothing written)
    /// when an address passes 65535 or the store is full.
    pub fn write_registers(&mut self, slave: usize, addr: u16, values: &[u16]) -> bool {
        let Some(regs) = self.registers.get_mut(slave) else {
            return false;
        };
        let mut addrs = Vec::with_capacity(values.len());
        for i in 0..values.len() {
            match u16::try_from(usize::from(addr) + i) {
                Ok(a) => addrs.push(a),
                Err(_) => return false,
            }
        }
        let new = addrs.iter().filter(|a| !regs.contains_key(a)).count();
        if regs.len() + new > MAX_REGISTERS {
            return false;
        }
        for (a, v) in addrs.into_iter().zip(values) {
            regs.insert(a, *v);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registers_read_back_and_stay_bounded() {
        let mut io = Io::default();
        assert!(io.write_registers(1, 5000, &[88, 89, 90]));
        assert_eq!(io.read_registers(1, 4999, 5).unwrap(), [0, 88, 89, 90, 0]);
        assert_eq!(io.read_registers(0, 5000, 1).unwrap(), [0]);
        assert!(!io.write_registers(0, 65535, &[1, 2]));
        assert!(io.read_registers(0, 65535, 2).is_none());
        assert!(io.read_registers(2, 0, 1).is_none());
        let many: Vec<u16> = vec![1; MAX_REGISTERS];
        assert!(io.write_registers(0, 0, &many));
        assert!(!io.write_registers(0, 60000, &[1]));
    }
}
