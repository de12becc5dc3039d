//! Contact laws and their solvers: the exact LCP solver ([`lcp`]) and the static contact
//! problem of a massless contact subsystem built on it ([`static_contact`], paper eqs. 26–29).

pub mod lcp;
pub mod static_contact;
