//! The stack budget check itself (no QEMU): a report over its firmware's
//! budget fails with a message naming the test, the figure and the
//! budget; one within passes.

use qemu_tests::{check_stack_budget, stack_budget, stack_used};

#[test]
fn a_report_over_the_budget_fails_and_names_test_figure_and_budget() {
    let budget = stack_budget("field-device").expect("the field device has a budget");
    let over = format!("stack_used={} stack_size=4182712 rx_frames=1", budget + 4);
    let e = check_stack_budget("field-device-web", "field-device", &over).unwrap_err();
    assert!(e.contains("field-device-web"), "{e}");
    assert!(e.contains(&format!("{} bytes", budget + 4)), "{e}");
    assert!(e.contains(&format!("budget of {budget} bytes")), "{e}");

    let at = format!("stack_used={budget} stack_size=4182712");
    assert_eq!(
        check_stack_budget("field-device-web", "field-device", &at),
        Ok(())
    );
}

#[test]
fn the_core_is_held_to_its_own_budget() {
    let core = stack_budget("gateway").expect("the core has a budget");
    let field = stack_budget("field-device").expect("the field device has a budget");
    assert!(core < field);
    // What the field device may use is too much for the core.
    let report = format!("stack_used={} stack_size=4182712", core + 1);
    assert!(check_stack_budget("gateway-modbus", "gateway", &report).is_err());
    assert!(check_stack_budget("field-device-web", "field-device", &report).is_ok());
}

#[test]
fn a_report_without_the_figure_fails() {
    assert_eq!(stack_used("stack_used=9384 stack_size=4182712"), Some(9384));
    assert_eq!(stack_used("rx_frames=1"), None);
    assert!(check_stack_budget("gateway-modbus", "gateway", "rx_frames=1").is_err());
    // A firmware without a budget (the smoke firmware) is not checked.
    assert_eq!(check_stack_budget("smoke", "smoke", "rx_frames=1"), Ok(()));
}
