//! An EDS (Electronic Data Sheet) writer: the text file Studio 5000 and
//! other configuration tools read to add the device, written from the same
//! [`Device`] and [`Identity`] the adapter serves, so that the two cannot
//! drift. It writes into any [`core::fmt::Write`] (a `heapless::String`, a
//! file through an adapter, a hasher).
//!
//! Sections: `[File]`, `[Device]`, `[Device Classification]`, `[Params]`
//! (the RPI), `[Assembly]` (every assembly, and the heartbeat connection
//! points as empty ones), `[Connection Manager]` (one entry per
//! [`IoConnection`]), `[Port]`, `[Capacity]`, and the class sections of the
//! Identity, TCP/IP Interface and Ethernet Link objects.
//!
//! ```
//! use hans_enip::device::*;
//! use hans_enip::eds::{write_eds, EdsInfo};
//! static ASM: [Assembly; 2] = [
//!     Assembly { instance: 100, kind: AssemblyKind::Input, size: 32, name: "Robot to PLC" },
//!     Assembly { instance: 150, kind: AssemblyKind::Output, size: 32, name: "PLC to robot" },
//! ];
//! static CONN: [IoConnection; 1] = [IoConnection {
//!     kind: ConnectionKind::ExclusiveOwner, o_to_t: 150, t_to_o: 100, config: 1, name: "Exclusive Owner",
//! }];
//! let device = Device { assemblies: &ASM, connections: &CONN };
//! let identity = Identity {
//!     vendor_id: 0xFFFE, device_type: 0x0C, product_code: 1,
//!     revision: Revision { major: 1, minor: 1 }, status: 0, serial: 1, product_name: "Gateway",
//! };
//! let mut text = heapless::String::<8192>::new();
//! write_eds(&mut text, &EdsInfo::new(&identity, &device, "Maker")).unwrap();
//! assert!(text.contains("VendCode = 65534;"));
//! assert!(text.contains("\"20 04 24 01 2C 96 2C 64\""));
//! ```

use core::fmt::{self, Write};

use crate::device::{AssemblyKind, ConnectionKind, Device, Identity, IoConnection, Revision};

/// What the EDS says besides the device description.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EdsInfo<'a> {
    /// The identity (vendor id, device type, product code, revision, name).
    pub identity: &'a Identity<'a>,
    /// The assemblies and connections.
    pub device: &'a Device<'a>,
    /// The vendor's name.
    pub vendor_name: &'a str,
    /// The device type's name (e.g. "Communications Adapter" for 0x0C).
    pub product_type_name: &'a str,
    /// The catalog number.
    pub catalog: &'a str,
    /// The file's description.
    pub description: &'a str,
    /// The file's creation date: year, month, day.
    pub date: (u16, u8, u8),
    /// The file's creation time: hours, minutes, seconds.
    pub time: (u8, u8, u8),
    /// The EDS file's own revision.
    pub file_revision: Revision,
    /// A URL for the file (empty: none).
    pub home_url: &'a str,
    /// The icon file's name (empty: none; tools show their default icon).
    pub icon: &'a str,
    /// The RPI range and default in microseconds (what the adapter accepts).
    pub rpi_us: (u32, u32, u32),
    /// The most connections (class 1 and 3) open at once.
    pub max_connections: u16,
}

impl<'a> EdsInfo<'a> {
    /// An EDS description with defaults: the RPI range of the adapter's
    /// default [`Config`](crate::Config) (2 ms to 10 s, 10 ms by default),
    /// dated 2026-01-01 (set `date` and `time` for a real file).
    pub fn new(identity: &'a Identity<'a>, device: &'a Device<'a>, vendor_name: &'a str) -> Self {
        EdsInfo {
            identity,
            device,
            vendor_name,
            product_type_name: "Communications Adapter",
            catalog: "",
            description: identity.product_name,
            date: (2026, 1, 1),
            time: (0, 0, 0),
            file_revision: Revision { major: 1, minor: 1 },
            home_url: "",
            icon: "",
            rpi_us: (2_000, 10_000_000, 10_000),
            max_connections: 8,
        }
    }
}

/// A quoted EDS string: `"` and `\` escaped, control characters dropped.
struct Quoted<'a>(&'a str);

impl fmt::Display for Quoted<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_char('"')?;
        for c in self.0.chars() {
            match c {
                '"' | '\\' => {
                    f.write_char('\\')?;
                    f.write_char(c)?;
                }
                c if c.is_control() => {}
                c => f.write_char(c)?,
            }
        }
        f.write_char('"')
    }
}

/// A logical segment as EDS path text: `24 64` or `25 00 2C 01`.
struct Seg(u8, u16);

impl fmt::Display for Seg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [lo, hi] = self.1.to_le_bytes();
        if hi == 0 {
            write!(f, "{:02X} {:02X}", self.0, lo)
        } else {
            write!(f, "{:02X} 00 {:02X} {:02X}", self.0 | 1, lo, hi)
        }
    }
}

/// Transport/trigger word of a connection entry: class 1 (bit 1), cyclic
/// (bit 16), and the application type (bit 24 listen-only, 25 input-only,
/// 26 exclusive owner).
fn trigger_transport(kind: ConnectionKind) -> u32 {
    let app = match kind {
        ConnectionKind::ListenOnly => 1 << 24,
        ConnectionKind::InputOnly => 1 << 25,
        _ => 1 << 26,
    };
    app | (1 << 16) | (1 << 1)
}

/// Connection parameters word: fixed sizes both ways (bits 0, 2), the O->T
/// real-time format (bits 8-10: 4, the 32-bit run/idle header, for an
/// exclusive owner; 3, a heartbeat, otherwise; the values common EDS files
/// use), T->O modeless (bits 12-14: 0), point-to-point both ways (bits 18,
/// 22: the adapter refuses multicast), scheduled priority (bits 26, 30).
fn connection_parameters(kind: ConnectionKind) -> u32 {
    let o_t_format = if kind == ConnectionKind::ExclusiveOwner {
        4
    } else {
        3
    };
    (1 << 30) | (1 << 26) | (1 << 22) | (1 << 18) | (o_t_format << 8) | (1 << 2) | 1
}

fn write_connection(
    w: &mut dyn Write,
    n: usize,
    c: &IoConnection<'_>,
    device: &Device<'_>,
) -> fmt::Result {
    let size = |instance: u16| device.assembly(instance).map_or(0, |a| a.size);
    writeln!(w, "        Connection{n} =")?;
    writeln!(
        w,
        "                0x{:08X},             $ trigger and transport",
        trigger_transport(c.kind)
    )?;
    writeln!(
        w,
        "                0x{:08X},             $ connection parameters",
        connection_parameters(c.kind)
    )?;
    writeln!(
        w,
        "                Param1,{},Assem{},    $ O->T RPI, size, format",
        size(c.o_to_t),
        c.o_to_t
    )?;
    writeln!(
        w,
        "                Param1,{},Assem{},    $ T->O RPI, size, format",
        size(c.t_to_o),
        c.t_to_o
    )?;
    writeln!(
        w,
        "                ,,                      $ proxy config size, format"
    )?;
    writeln!(
        w,
        "                ,,                      $ target config size, format"
    )?;
    writeln!(w, "                {},", Quoted(c.name))?;
    writeln!(w, "                \"\",                     $ help")?;
    writeln!(
        w,
        "                \"20 04 {} {} {}\";",
        Seg(0x24, c.config),
        Seg(0x2C, c.o_to_t),
        Seg(0x2C, c.t_to_o)
    )
}

/// Writes the EDS text.
pub fn write_eds(w: &mut dyn Write, info: &EdsInfo<'_>) -> fmt::Result {
    let id = info.identity;
    let (y, mo, d) = info.date;
    let (h, mi, s) = info.time;
    writeln!(
        w,
        "$ EDS of {}, written by hans-enip from the device's own description",
        id.product_name
    )?;
    writeln!(w)?;
    writeln!(w, "[File]")?;
    writeln!(w, "        DescText = {};", Quoted(info.description))?;
    writeln!(w, "        CreateDate = {mo:02}-{d:02}-{y:04};")?;
    writeln!(w, "        CreateTime = {h:02}:{mi:02}:{s:02};")?;
    writeln!(
        w,
        "        Revision = {}.{};",
        info.file_revision.major, info.file_revision.minor
    )?;
    if !info.home_url.is_empty() {
        writeln!(w, "        HomeURL = {};", Quoted(info.home_url))?;
    }
    writeln!(w)?;
    writeln!(w, "[Device]")?;
    writeln!(w, "        VendCode = {};", id.vendor_id)?;
    writeln!(w, "        VendName = {};", Quoted(info.vendor_name))?;
    writeln!(w, "        ProdType = {};", id.device_type)?;
    writeln!(
        w,
        "        ProdTypeStr = {};",
        Quoted(info.product_type_name)
    )?;
    writeln!(w, "        ProdCode = {};", id.product_code)?;
    writeln!(w, "        MajRev = {};", id.revision.major)?;
    writeln!(w, "        MinRev = {};", id.revision.minor)?;
    writeln!(w, "        ProdName = {};", Quoted(id.product_name))?;
    writeln!(w, "        Catalog = {};", Quoted(info.catalog))?;
    if !info.icon.is_empty() {
        writeln!(w, "        Icon = {};", Quoted(info.icon))?;
    }
    writeln!(w)?;
    writeln!(w, "[Device Classification]")?;
    writeln!(w, "        Class1 = EtherNetIP;")?;
    writeln!(w)?;
    let (min, max, default) = info.rpi_us;
    writeln!(w, "[Params]")?;
    writeln!(w, "        Param1 =")?;
    writeln!(w, "                0,                      $ reserved")?;
    writeln!(
        w,
        "                ,,                      $ link path size, link path"
    )?;
    writeln!(w, "                0x0000,                 $ descriptor")?;
    writeln!(
        w,
        "                0xC8,                   $ data type: UDINT"
    )?;
    writeln!(w, "                4,                      $ data size")?;
    writeln!(w, "                \"RPI\",")?;
    writeln!(w, "                \"microsecond\",")?;
    writeln!(w, "                \"Requested packet interval\",")?;
    writeln!(
        w,
        "                {min},{max},{default},    $ min, max, default"
    )?;
    writeln!(w, "                ,,,,                    $ scaling")?;
    writeln!(w, "                ,,,,                    $ links")?;
    writeln!(
        w,
        "                ;                       $ decimal places"
    )?;
    writeln!(w)?;
    writeln!(w, "[Assembly]")?;
    writeln!(w, "        Object_Name = \"Assembly Object\";")?;
    writeln!(w, "        Object_Class_Code = 0x04;")?;
    for a in info.device.assemblies {
        let what = match a.kind {
            AssemblyKind::Input => "input",
            AssemblyKind::Output => "output",
            AssemblyKind::Config => "configuration",
        };
        writeln!(w, "        Assem{} =                  $ {what}", a.instance)?;
        writeln!(w, "                {},", Quoted(a.name))?;
        writeln!(
            w,
            "                \"20 04 {} 30 03\",",
            Seg(0x24, a.instance)
        )?;
        writeln!(w, "                {},", a.size)?;
        writeln!(w, "                0x0000,")?;
        writeln!(w, "                ,,")?;
        writeln!(w, "                {},;", u32::from(a.size) * 8)?;
    }
    // The heartbeat points of input-only and listen-only connections: no data.
    for (i, c) in info.device.connections.iter().enumerate() {
        let first = info
            .device
            .connections
            .iter()
            .position(|x| x.o_to_t == c.o_to_t)
            == Some(i);
        if first && info.device.assembly(c.o_to_t).is_none() {
            writeln!(
                w,
                "        Assem{} =                  $ heartbeat",
                c.o_to_t
            )?;
            writeln!(w, "                {},", Quoted(c.name))?;
            writeln!(w, "                \"\",")?;
            writeln!(w, "                0,")?;
            writeln!(w, "                0x0000,")?;
            writeln!(w, "                ,,;")?;
        }
    }
    writeln!(w)?;
    writeln!(w, "[Connection Manager]")?;
    writeln!(w, "        Object_Name = \"Connection Manager Object\";")?;
    writeln!(w, "        Object_Class_Code = 0x06;")?;
    for (i, c) in info.device.connections.iter().enumerate() {
        if c.kind != ConnectionKind::Explicit {
            write_connection(w, i + 1, c, info.device)?;
        }
    }
    writeln!(w)?;
    writeln!(w, "[Port]")?;
    writeln!(w, "        Object_Name = \"Port Object\";")?;
    writeln!(w, "        Object_Class_Code = 0xF4;")?;
    writeln!(w, "        Port1 =")?;
    writeln!(w, "                TCP,                    $ port type")?;
    writeln!(w, "                \"EtherNet/IP Port\",")?;
    writeln!(
        w,
        "                \"20 F5 24 01\",          $ the TCP/IP Interface object"
    )?;
    writeln!(w, "                2;                      $ port number")?;
    writeln!(w)?;
    writeln!(w, "[Capacity]")?;
    writeln!(w, "        MaxCIPConnections = {};", info.max_connections)?;
    writeln!(w)?;
    for (name, object, code) in [
        ("Identity Class", "Identity Object", 0x01),
        ("TCP/IP Interface Class", "TCP/IP Interface Object", 0xF5),
        ("Ethernet Link Class", "Ethernet Link Object", 0xF6),
    ] {
        writeln!(w, "[{name}]")?;
        writeln!(w, "        Object_Name = \"{object}\";")?;
        writeln!(w, "        Object_Class_Code = 0x{code:02X};")?;
        writeln!(w, "        MaxInst = 1;")?;
        writeln!(w, "        Number_Of_Static_Instances = 1;")?;
        writeln!(w, "        Max_Number_Of_Dynamic_Instances = 0;")?;
        writeln!(w)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Assembly;

    static ASM: [Assembly<'static>; 3] = [
        Assembly {
            instance: 100,
            kind: AssemblyKind::Input,
            size: 32,
            name: "Robot \"state\"",
        },
        Assembly {
            instance: 0x150,
            kind: AssemblyKind::Output,
            size: 16,
            name: "Commands",
        },
        Assembly {
            instance: 1,
            kind: AssemblyKind::Config,
            size: 0,
            name: "Config",
        },
    ];
    static CONN: [IoConnection<'static>; 3] = [
        IoConnection {
            kind: ConnectionKind::ExclusiveOwner,
            o_to_t: 0x150,
            t_to_o: 100,
            config: 1,
            name: "Owner",
        },
        IoConnection {
            kind: ConnectionKind::InputOnly,
            o_to_t: 198,
            t_to_o: 100,
            config: 1,
            name: "Input Only",
        },
        IoConnection {
            kind: ConnectionKind::ListenOnly,
            o_to_t: 199,
            t_to_o: 100,
            config: 1,
            name: "Listen Only",
        },
    ];

    fn eds() -> heapless::String<8192> {
        let device = Device {
            assemblies: &ASM,
            connections: &CONN,
        };
        let id = Identity {
            vendor_id: 0xFFFE,
            device_type: 0x0C,
            product_code: 7,
            revision: Revision { major: 2, minor: 3 },
            status: 0,
            serial: 1,
            product_name: "Gate\\way",
        };
        let mut s = heapless::String::new();
        write_eds(&mut s, &EdsInfo::new(&id, &device, "Maker\n")).unwrap();
        s
    }

    #[test]
    fn sections_and_values() {
        let s = eds();
        for section in [
            "[File]",
            "[Device]",
            "[Device Classification]",
            "[Params]",
            "[Assembly]",
            "[Connection Manager]",
            "[Port]",
            "[Capacity]",
        ] {
            assert!(s.contains(section), "{section}");
        }
        assert!(s.contains("        VendCode = 65534;\n"));
        assert!(s.contains("        ProdCode = 7;\n        MajRev = 2;\n        MinRev = 3;\n"));
        assert!(s.contains("ProdName = \"Gate\\\\way\";"), "escaped");
        assert!(
            s.contains("VendName = \"Maker\";"),
            "control characters dropped"
        );
        assert!(s.contains("\"Robot \\\"state\\\"\","));
        assert!(s.contains("2000,10000000,10000,"));
        // A 16-bit instance in a path, connection entries with their sizes.
        assert!(s.contains("\"20 04 25 00 50 01 30 03\""));
        assert!(s.contains("\"20 04 24 01 2D 00 50 01 2C 64\";"));
        assert!(
            s.contains("0x04010002,"),
            "exclusive owner, class 1, cyclic"
        );
        assert!(s.contains("0x02010002,"), "input only");
        assert!(s.contains("0x01010002,"), "listen only");
        assert!(s.contains("0x44440405,"));
        assert!(s.contains("0x44440305,"));
        assert!(s.contains("Param1,16,Assem336,"));
        assert!(s.contains("Param1,0,Assem198,"));
        assert!(
            s.contains("Assem198 =") && s.contains("Assem199 ="),
            "heartbeat points"
        );
    }

    #[test]
    fn a_buffer_too_small_is_an_error_not_a_panic() {
        let device = Device {
            assemblies: &ASM,
            connections: &CONN,
        };
        let id = Identity {
            vendor_id: 1,
            device_type: 0x0C,
            product_code: 1,
            revision: Revision { major: 1, minor: 1 },
            status: 0,
            serial: 1,
            product_name: "x",
        };
        let mut s = heapless::String::<256>::new();
        assert!(write_eds(&mut s, &EdsInfo::new(&id, &device, "m")).is_err());
    }
}
