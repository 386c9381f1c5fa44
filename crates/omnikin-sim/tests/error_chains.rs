//! Errors that wrap a cause print it once: an error's message and its `source` chain (what
//! `anyhow`'s `{:#}` prints, joined by ": ") name the cause a single time.

use omnikin::control::BalanceError;
use omnikin::{GeometryError, InputError};
use omnikin_plan::PlanningError;
use omnikin_sim::dynamics::ballbot::plan_run::PlanRunError;

/// The message and every source's message, as an error chain prints them.
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cur = e.source();
    while let Some(c) = cur {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cur = c.source();
    }
    s
}

#[test]
fn a_wrapped_cause_is_printed_once() {
    let geometry = GeometryError::NonFinite {
        field: "ball_radius",
    };
    let input = InputError::NonFinite { field: "vx" };
    let cases: [(&dyn std::error::Error, &str, String); 4] = [
        (
            &BalanceError::from(geometry),
            "ballbot geometry: ",
            geometry.to_string(),
        ),
        (
            &PlanningError::from(input),
            "kinematics: ",
            input.to_string(),
        ),
        (
            &PlanRunError::from(BalanceError::from(geometry)),
            "ballbot geometry: ",
            geometry.to_string(),
        ),
        (&PlanRunError::from(input), "", input.to_string()),
    ];
    for (e, prefix, cause) in cases {
        let text = chain(e);
        assert_eq!(text.matches(cause.as_str()).count(), 1, "{text}");
        assert_eq!(text, format!("{prefix}{cause}"));
    }
}
