//! REGISTERS.md is the PLC programmer's copy of the register map: its
//! table must match `registers::TABLE` row by row, and its command-code
//! table the codes the engine knows, and its error-code table the
//! gateway's own codes.

use hans_gateway::error::GatewayError;
use hans_gateway::job::{build, code, Inputs};
use hans_gateway::registers::{Access, TABLE};

fn doc() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/REGISTERS.md"))
        .expect("REGISTERS.md")
}

fn cells(line: &str) -> Vec<String> {
    line.trim()
        .trim_matches('|')
        .split('|')
        .map(|c| c.trim().to_string())
        .collect()
}

/// The rows of the table after `heading`.
fn table_after(doc: &str, heading: &str) -> Vec<Vec<String>> {
    let start = doc.find(heading).unwrap_or_else(|| panic!("no {heading}"));
    doc[start..]
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .map(cells)
        .collect()
}

#[test]
fn the_documented_map_is_the_map() {
    let rows = table_after(&doc(), "## The map");
    assert_eq!(rows.len(), TABLE.len(), "number of rows");
    for (row, area) in rows.iter().zip(TABLE) {
        let access = match area.access {
            Access::Ro => "RO",
            Access::Rw => "RW",
        };
        assert_eq!(
            (
                row[0].as_str(),
                row[1].parse::<u16>().ok(),
                row[2].parse::<u16>().ok(),
                row[3].as_str(),
                row[4].as_str()
            ),
            (
                area.name,
                Some(area.start),
                Some(area.len),
                area.ty.name(),
                access
            ),
            "row {row:?}"
        );
        assert!(!row[5].is_empty(), "{} has no description", area.name);
    }
}

#[test]
fn the_documented_command_codes_are_the_engine_codes() {
    let rows = table_after(&doc(), "| Code | Command |");
    // A row is one code or a range `a-b` (the jog codes).
    let codes: Vec<u16> = rows
        .iter()
        .flat_map(|r| match r[0].split_once('-') {
            Some((a, b)) => a.parse().expect("code")..=b.parse().expect("code"),
            None => {
                let c: u16 = r[0].parse().expect("code");
                c..=c
            }
        })
        .collect();
    assert_eq!(codes.len(), 23 + 24);
    // Valid for every command: axis/bit 1, value/distance 1, velocity and
    // acceleration 10.
    let params = [1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 10.0, 10.0, 0.0, 0.0, 0.0, 0.0];
    let inputs = |code, params| Inputs {
        code,
        params,
        text1: "Func_1",
        text2: "",
        seq: 1,
        joints: None,
    };
    for c in 0..=255u16 {
        let built = build(&inputs(c, &params), 0);
        let documented = codes.contains(&c);
        assert_eq!(built.is_ok(), documented, "code {c}: {built:?}");
    }
    let jogs: Vec<u16> = (code::JOG_J..code::JOG_J + 12)
        .chain(code::JOG_L..code::JOG_L + 12)
        .collect();
    assert_eq!(codes, [&code::ALL[..], &jogs[..]].concat());
}

/// Every [`GatewayError`]: the match in `position` fails to compile when a
/// variant is added, until [`GatewayError::ALL`] lists it too.
const GATEWAY_ERRORS: [GatewayError; 15] = GatewayError::ALL;

fn position(e: GatewayError) -> usize {
    match e {
        GatewayError::NotConnected => 0,
        GatewayError::BadParameter => 1,
        GatewayError::BadReply => 2,
        GatewayError::ReplyTimeout => 3,
        GatewayError::ConnectFailed => 4,
        GatewayError::ReplyMismatch => 5,
        GatewayError::QueueFull => 6,
        GatewayError::LinkLost => 7,
        GatewayError::Watchdog => 8,
        GatewayError::TriggerEmpty => 9,
        GatewayError::RobotErrorNoCode => 10,
        GatewayError::EmergencyStop => 11,
        GatewayError::SafetyGuard => 12,
        GatewayError::StateNotReached => 13,
        GatewayError::NotSupported => 14,
    }
}

/// Finding: a paragraph inside the error-code table cut it in two, and
/// the codes after it no longer rendered as rows. The table, read as
/// Markdown reads it (up to its first non-row line), must hold exactly the
/// gateway's codes, each with a meaning.
#[test]
fn the_documented_error_codes_are_the_gateway_codes() {
    for (i, e) in GATEWAY_ERRORS.iter().enumerate() {
        assert_eq!(position(*e), i, "{e:?} listed once, in order");
    }
    let rows = table_after(&doc(), "## Error codes");
    let documented: Vec<i32> = rows
        .iter()
        .map(|r| {
            assert!(r.len() == 2 && !r[1].is_empty(), "row {r:?}");
            r[0].parse().unwrap_or_else(|_| panic!("code in {r:?}"))
        })
        .collect();
    let codes: Vec<i32> = GATEWAY_ERRORS.iter().map(|e| e.code()).collect();
    assert_eq!(documented, codes);
}

/// Finding (doc gap): reads across unmapped gaps give exception 02, so the
/// doc must say which blocks to read. Its block table must be exactly the
/// gap-free runs of the map.
#[test]
fn the_documented_blocks_are_the_gap_free_runs_of_the_map() {
    // The runs of TABLE: areas that follow each other without a gap.
    let mut runs: Vec<(u16, u16)> = Vec::new();
    for a in TABLE {
        match runs.last_mut() {
            Some((_, end)) if *end + 1 == a.start => *end = a.start + a.len - 1,
            _ => runs.push((a.start, a.start + a.len - 1)),
        }
    }
    let rows = table_after(&doc(), "### The blocks to read");
    let mut documented = Vec::new();
    for row in &rows {
        let (first, last, count) = (&row[1], &row[2], row[3].parse::<u16>().expect("count"));
        if let (Ok(f), Ok(l)) = (first.parse::<u16>(), last.parse::<u16>()) {
            assert_eq!(l - f + 1, count, "{row:?}");
            documented.push((f, l));
        } else {
            // "1200 + 100 × n": one row for the sixteen trigger entries.
            let base = |t: &str| t.split(' ').next().and_then(|v| v.parse::<u16>().ok());
            let (f, l) = (base(first).expect("first"), base(last).expect("last"));
            assert_eq!(l - f + 1, count, "{row:?}");
            for n in 0..16 {
                documented.push((f + 100 * n, l + 100 * n));
            }
        }
    }
    assert_eq!(documented, runs);
}

/// Finding: the example's "Write 200-227" covered P0-P11 while its values
/// were Execute, code, sequence, reserved and P0-P8. Every range the example
/// writes must hold exactly the values it lists: `A-B = `[v, ...]`` (or
/// "write A-B with FC 16: `[...]`") one register a value, starting at
/// channel 0's block; `A-B = Pm-Pn as f32 pairs (K registers` two a value.
#[test]
fn the_example_write_range_holds_exactly_its_values() {
    let doc = doc();
    let start = doc
        .find("## Example: from power-off to a linear move")
        .expect("the example");
    let example = &doc[start..];
    let example = &example[..example.find("\n## ").unwrap_or(example.len())];
    // "A-B" just before `at`, if the text there ends with one.
    let range_before = |at: usize| -> Option<(u16, u16)> {
        let head = example[..at].trim_end();
        let word = head.rsplit(' ').next()?;
        let (a, b) = word.split_once('-')?;
        Some((a.parse().ok()?, b.parse().ok()?))
    };
    let (mut lists, mut pairs) = (0, 0);
    for marker in [" = `[", " with FC 16: `["] {
        for (at, _) in example.match_indices(marker) {
            let Some((a, b)) = range_before(at) else {
                continue;
            };
            let values = &example[at + marker.len()..];
            let values = &values[..values.find(']').expect("the list's end")];
            let n = values.split(", ").count() as u16;
            assert_eq!(b - a + 1, n, "{a}-{b} = [{values}]");
            assert_eq!(a, hans_gateway::registers::channel_base(0));
            lists += 1;
        }
    }
    for (at, _) in example.match_indices(" as f32 pairs (") {
        let head = &example[..at];
        let ps = head.rsplit(' ').next().expect("Pm-Pn");
        let (m, n) = ps.trim_start_matches('P').split_once("-P").expect("Pm-Pn");
        let values = n.parse::<u16>().expect("n") - m.parse::<u16>().expect("m") + 1;
        let eq = head[..head.len() - ps.len()].trim_end();
        let eq = eq.strip_suffix('=').expect("A-B = Pm-Pn").trim_end();
        let (a, b) = range_before(eq.len()).expect("A-B");
        let k: u16 = example[at + " as f32 pairs (".len()..]
            .split(' ')
            .next()
            .and_then(|k| k.parse().ok())
            .expect("(K registers");
        assert_eq!(b - a + 1, 2 * values, "{a}-{b} = {ps}");
        assert_eq!(k, 2 * values, "{a}-{b} = {ps} ({k} registers");
        pairs += 1;
    }
    assert!(
        lists >= 3 && pairs >= 1,
        "the example's writes not found ({lists}, {pairs})"
    );
}

/// Finding: VERSION said "gateway version (0x0100 = 1.0)" while
/// `hans-gateway --version` printed 0.1.0. It is the register map's version:
/// the example in its row must be the value the gateway reports.
#[test]
fn the_documented_version_is_the_map_version() {
    let rows = table_after(&doc(), "## The map");
    let row = rows
        .iter()
        .find(|r| r[0] == "VERSION")
        .expect("a VERSION row");
    let v = hans_gateway::registers::MAP_VERSION;
    let example = format!("0x{v:04X} = {}.{}", v >> 8, v & 0xFF);
    assert!(row[5].contains(&example), "{:?} lacks {example:?}", row[5]);
    assert!(row[5].contains("Register map version"), "{:?}", row[5]);
}
