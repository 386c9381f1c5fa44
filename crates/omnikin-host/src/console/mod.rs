//! The console: the [`hub::Hub`] where the pages' commands and the robot's stream meet, the
//! [`relay`] that owns the robot link (an operator session) and turns telemetry into the pages'
//! JSON, the recording and the Foxglove stream ([`foxglove_hub`]), the map the pages draw
//! ([`map_view`]), and the web server ([`server::ConsoleServer`]: the page, its WebSocket, the
//! access rules — [`gate`], [`http`], [`ws`], [`foxglove_ws`]) that `omnikin console` runs.

pub mod foxglove_hub;
pub mod foxglove_ws;
pub mod gate;
pub mod http;
pub mod hub;
pub mod map_view;
pub mod relay;
pub mod server;
pub mod ws;
