pub mod labelled;
pub mod rk4;
