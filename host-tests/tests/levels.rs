//! Protocol levels: the revision data of the table, and the check before
//! sending. Runs in every build; the V6 commands' part with `v6`.

use hans_codec::{
    request, Command, CommandId, EncodeError, LevelError, ProtocolLevel, Request, RobotId,
};

fn level(s: &str) -> ProtocolLevel {
    ProtocolLevel::parse(s).unwrap_or_else(|| panic!("{s}"))
}

#[test]
fn every_command_of_hr_tcp_is_there_at_v5_but_those_removed_later_stay() {
    for &id in CommandId::ALL {
        if id.section_v5().is_some() {
            assert_eq!(id.since(), ProtocolLevel::V5, "{id}");
            assert!(id.available_at(ProtocolLevel::V5), "{id}");
        }
        // A command is never removed before it came.
        if let Some(r) = id.removed() {
            assert!(r > id.since(), "{id}");
        }
        // Every command of the V6 document is available at some level of
        // it, and the V6 level has every command the document keeps.
        if id.section_v6().is_some() {
            assert_eq!(
                id.available_at(ProtocolLevel::V6),
                id.removed().is_none(),
                "{id}"
            );
        }
    }
}

#[test]
fn the_revision_table_as_data() {
    assert_eq!(CommandId::MoveJ.removed(), Some(level("HR5.50.3")));
    assert_eq!(CommandId::MoveL.removed(), Some(level("HR5.50.3")));
    assert_eq!(CommandId::MoveE.removed(), Some(level("HR6.5.0")));
    assert_eq!(CommandId::MoveE.changed(), Some(level("HR6.4.8")));
    assert_eq!(CommandId::ReadBoxInfo.changed(), Some(level("HR6.3.3")));
    assert_eq!(CommandId::WayPoint.removed(), None);
    assert_eq!(CommandId::WayPoint.section_v6(), Some("4.10.5"));
    assert_eq!(CommandId::MoveJ.section_v6(), None);
    // MoveJ exists up to HR5.50.2.
    assert!(CommandId::MoveJ.available_at(ProtocolLevel::new(5, 50, 2)));
    assert!(!CommandId::MoveJ.available_at(level("HR5.50.3")));
}

#[test]
fn a_removed_command_is_refused_before_anything_is_written() {
    let r = request::MoveJ {
        tcp_name: "TCP",
        ucs_name: "Base",
        cmd_id: "1",
        ..Default::default()
    };
    let e = r.check_level(ProtocolLevel::V6).unwrap_err();
    assert_eq!(
        e,
        LevelError::Removed {
            command: CommandId::MoveJ,
            removed: level("HR5.50.3"),
            level: ProtocolLevel::V6,
        }
    );
    assert_eq!(e.command(), CommandId::MoveJ);
    let mut buf = [0xAAu8; 256];
    assert_eq!(
        Request::from(r.clone()).encode_at(ProtocolLevel::V6, &mut buf),
        Err(EncodeError::Unsupported(e))
    );
    assert!(buf.iter().all(|&b| b == 0xAA), "nothing written");
    // At V5 it is written as `encode` writes it.
    let mut a = [0u8; 256];
    let mut b = [0u8; 256];
    let n = r.encode_at(ProtocolLevel::V5, &mut a).unwrap();
    assert_eq!(r.encode(&mut b), Ok(n));
    assert_eq!(a[..n], b[..n]);
    assert_eq!(
        EncodeError::Unsupported(e).to_string(),
        "MoveJ was removed at HR5.50.3 (level HR6.6.1)"
    );
}

#[test]
fn unknown_names_pass_at_every_level() {
    let r = Request::parse("ReadVersion,0,;").unwrap();
    assert_eq!(r.command(), None);
    assert!(r.check_level(ProtocolLevel::V5).is_ok());
    assert!(r.check_level(ProtocolLevel::V6).is_ok());
    let g = request::GrpEnable { rbt_id: RobotId(0) };
    assert!(g.check_level(ProtocolLevel::V5).is_ok());
    assert!(g.check_level(ProtocolLevel::V6).is_ok());
}

#[test]
fn levels_read_and_print_as_the_documents_write_them() {
    assert_eq!(level("HR6.4.8").to_string(), "HR6.4.8");
    assert_eq!(ProtocolLevel::V5.to_string(), "V5");
    assert_eq!(ProtocolLevel::V6.to_string(), "HR6.6.1");
    // A `PackageVersion` reply gives the controller's level.
    assert_eq!(level("6.3.6.20240305"), ProtocolLevel::new(6, 3, 6));
    assert_eq!(ProtocolLevel::V6.parts(), (6, 6, 1));
}

#[cfg(feature = "v6")]
mod v6 {
    use super::*;

    #[test]
    fn a_v6_command_is_refused_at_v5_and_before_its_version() {
        let jog = request::LongJogJ {
            rbt_id: RobotId(0),
            axis: 1,
            direction: 1,
            state: 1,
        };
        let e = jog.check_level(ProtocolLevel::V5).unwrap_err();
        assert_eq!(
            e,
            LevelError::TooNew {
                command: CommandId::LongJogJ,
                since: level("HR6.2.17"),
                level: ProtocolLevel::V5,
            }
        );
        assert_eq!(e.to_string(), "LongJogJ needs HR6.2.17 (level V5)");
        assert!(jog.check_level(level("HR6.2.17")).is_ok());
        assert!(jog.check_level(ProtocolLevel::V6).is_ok());
        let mut buf = [0u8; 64];
        assert!(matches!(
            jog.encode_at(ProtocolLevel::V5, &mut buf),
            Err(EncodeError::Unsupported(_))
        ));
        let text = b"LongJogJ,0,1,1,1,;";
        assert_eq!(jog.encode_at(ProtocolLevel::V6, &mut buf), Ok(text.len()));
        assert_eq!(&buf[..text.len()], text);
    }

    #[test]
    fn renamed_and_removed_at_the_v6_level() {
        // EnterSafeGuard from HR6.5.1; its old name from HR6.2.17, kept.
        assert!(!CommandId::EnterSafeGuard.available_at(level("HR6.4.17")));
        assert!(CommandId::EnterSafetyGuard.available_at(level("HR6.4.17")));
        assert!(CommandId::EnterSafetyGuard.available_at(ProtocolLevel::V6));
        // The old path commands go at HR6.5, the new ones come at HR6.3.3.
        for id in [
            CommandId::StartPushMovePath,
            CommandId::PushMovePaths,
            CommandId::InitMovePathL,
        ] {
            assert!(id.available_at(level("HR6.4.17")), "{id}");
            assert!(!id.available_at(level("HR6.5.0")), "{id}");
        }
        assert!(CommandId::InitPath.available_at(level("HR6.3.3")));
        assert!(!CommandId::InitPath.available_at(level("HR6.3.2")));
        // ReadOverride is as old as HR-TCP V1.0.0.3's controllers.
        assert!(CommandId::ReadOverride.available_at(ProtocolLevel::V5));
    }

    #[test]
    fn the_v6_commands_count() {
        let new: Vec<_> = CommandId::ALL
            .iter()
            .filter(|id| id.section_v5().is_none())
            .collect();
        assert_eq!(new.len(), 74);
        assert!(new.iter().all(|id| id.section_v6().is_some()));
    }
}
