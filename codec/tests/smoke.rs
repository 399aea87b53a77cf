use hans_codec::*;

fn rt(line: &str) -> String {
    let r = Request::parse(line).unwrap_or_else(|e| panic!("{line}: {e}"));
    let mut b = [0u8; 1024];
    let n = r.encode(&mut b).unwrap();
    String::from_utf8(b[..n].to_vec()).unwrap()
}

#[test]
fn smoke() {
    assert_eq!(rt("OSCmd,1;"), "OSCmd,1,;");
    assert_eq!(rt("ConnectToBox,0,;"), "ConnectToBox,;");
    assert_eq!(
        rt("SetJointMaxAcc,0,360, 360, 360, 360, 360, 360,;"),
        "SetJointMaxAcc,0,360,360,360,360,360,360,;"
    );
    assert_eq!(
        rt("MoveS,0,1,5,30,30,1,TCP,Base,1,;"),
        "MoveS,0,1,5,30,30,1,TCP,Base,1,;"
    );
    assert_eq!(
        rt("MoveS,0,1,5,TCP,Base,30,30,1,1,;"),
        "MoveS,0,1,5,30,30,1,TCP,Base,1,;"
    );
    assert_eq!(
        rt("MoveJ,0,420,0,445,180,0,180,0,0,90,0,90,0,TCP,Base,50,360,0,0,1,0,0,0,0,;"),
        "MoveJ,0,420,0,445,180,0,180,0,0,90,0,90,0,TCP,Base,50,360,0,1,0,0,0,0,;"
    );
    assert_eq!(rt("ReadBoxInfo,;"), "ReadBoxInfo,0,;");
    assert_eq!(rt("GrpPowerOn,0,;"), "GrpEnable,0,;");
    assert_eq!(
        rt("PushMovePaths,0,Path1,1,2,420,0,445,180,0,180,420,10,445,180,0,180,;"),
        "PushMovePaths,0,Path1,1,2,420,0,445,180,0,180,420,10,445,180,0,180,;"
    );
    assert_eq!(
        rt("WriteHoldingRegisters, 0,1,16,5000,5,88,89,90,91,92,;"),
        "WriteHoldingRegisters,0,1,16,5000,5,88,89,90,91,92,;"
    );
    assert_eq!(rt("RunFunc,Func_1,55,;"), "RunFunc,Func_1,55,;");
    assert_eq!(rt("NewCmd,1, a ,;"), "NewCmd,1,a,;");
    let e = Request::parse(
        "WayPoint, 0,420, 0,445, 180, 0,180, 0,090, 0,90, 0, TCP, Base, 50,360, 0,0,1,0,0,0,0;",
    )
    .unwrap_err();
    println!("{e}");
    let e = Request::parse("Quaternion2RPY,0,0,0,0,;").unwrap_err();
    println!("{e}");
    let req = Request::parse("ReadBoxDI,5,6,;").unwrap();
    assert!(matches!(
        Reply::parse("ReadBoxDI,OK,0,1,;", req.expect()),
        Ok(Reply::Ok(_))
    ));
    let e = Reply::parse("ReadBoxDI,OK,0,1,1,;", req.expect()).unwrap_err();
    println!("{e}");
    let r = Reply::parse(
        "ReadActPos,Fail,20018,bad, thing,;",
        ReplyExpect::from_name("ReadActPos"),
    )
    .unwrap();
    println!("{r:?}");
    let r = Reply::parse(
        "ReadBoxInfo,OK,1,1,48.000,0.000,0,0,;",
        ReplyExpect::from_name("ReadBoxInfo"),
    )
    .unwrap();
    let mut b = [0u8; 256];
    let n = r.encode(&mut b).unwrap();
    assert_eq!(&b[..n], b"ReadBoxInfo,OK,1,1,48.000,0.000,0,0,;");
    let r = Reply::parse(
        "ReadCmdJointCur,OK,-0.000,-0.000,-0.000,-0.000,-0.000,;",
        ReplyExpect::from_name("ReadCmdJointCur"),
    )
    .unwrap_err();
    println!("{r}");
}
