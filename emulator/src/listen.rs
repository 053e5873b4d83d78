//! Binding the ports `serve` and `record` listen on, with an error that says which port it was
//! and at which address: "Address already in use" alone did not say whether the host port or
//! the control port was taken (issue 19).

use std::io;
use std::net::{SocketAddr, TcpListener};

/// Binds `addr` for `port` (`host port`, `control port`); an error names both.
pub fn bind(port: &str, addr: SocketAddr) -> io::Result<TcpListener> {
    TcpListener::bind(addr).map_err(|e| io::Error::new(e.kind(), format!("{port} {addr}: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_port_in_use_is_named_with_its_address_and_role() {
        let taken = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = taken.local_addr().unwrap();
        let e = bind("control port", addr).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::AddrInUse);
        let text = e.to_string();
        assert!(text.starts_with(&format!("control port {addr}: ")), "{text}");
    }
}
