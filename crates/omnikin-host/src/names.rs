//! How a front end names the options that a host-side error points to: the CLI's flags
//! (`--key FILE`) or Python's keywords (`key=`), so that a message tells the user what to
//! change in the program they are using.

/// The names of the link's options in one front end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OptionNames {
    /// The robot's address an operator connects to.
    pub connect: &'static str,
    /// The address a robot listens on.
    pub listen: &'static str,
    /// The shared key file.
    pub key: &'static str,
    /// The heartbeat rate, Hz.
    pub heartbeat: &'static str,
    /// The timeout, s.
    pub timeout: &'static str,
    /// The MCAP log.
    pub mcap: &'static str,
    /// The robot's CSV log.
    pub log: &'static str,
    /// What serves a robot, as the message "is … running there" names it.
    pub robot_program: &'static str,
}

impl OptionNames {
    /// `omnikin drive` / `omnikin robot`'s flags.
    pub const CLI: OptionNames = OptionNames {
        connect: "--connect",
        listen: "--listen",
        key: "--key",
        heartbeat: "--heartbeat",
        timeout: "--timeout",
        mcap: "--mcap",
        log: "--log",
        robot_program: "`omnikin robot`",
    };

    /// Python's `omnikin.Link` / `omnikin.SimRobot` keywords.
    pub const PYTHON: OptionNames = OptionNames {
        connect: "connect",
        listen: "listen",
        key: "key",
        heartbeat: "heartbeat_hz",
        timeout: "timeout_s",
        mcap: "mcap",
        log: "log",
        robot_program: "omnikin robot or omnikin.SimRobot",
    };
}
