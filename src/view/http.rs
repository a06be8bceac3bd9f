//! A small HTTP/1.1 server for the viewer: GET and HEAD of a fixed set of routes, byte
//! ranges (a browser seeks in audio by asking for ranges), one thread per connection. It
//! listens on 127.0.0.1 only.

use std::io::{BufRead, BufReader, Read, Seek, SeekFrom, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// What a route answers with.
#[derive(Debug, Clone)]
pub enum Body {
    /// Bytes held in memory (the page, three.js, generated JSON).
    Bytes(Arc<[u8]>),
    /// A file read at each request (the render's WAV and glb, which can be large).
    File(PathBuf),
    /// A WebSocket, handed to its handler once the handshake is answered (the live avatar's
    /// pose stream, the video recorder's frames).
    Socket(Arc<dyn SocketHandler>),
}

/// What serves a WebSocket route: it takes the connection after the handshake.
pub trait SocketHandler: Send + Sync + std::fmt::Debug {
    fn serve(&self, stream: TcpStream);
}

/// One route: its path, content type and body.
#[derive(Debug, Clone)]
pub struct Route {
    pub path: String,
    pub content_type: &'static str,
    pub body: Body,
}

/// The content type for a file name's extension.
pub fn content_type(name: &str) -> &'static str {
    match name.rsplit('.').next().unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" => "text/javascript; charset=utf-8",
        "json" => "application/json",
        "css" => "text/css; charset=utf-8",
        "wav" => "audio/wav",
        "glb" => "model/gltf-binary",
        _ => "application/octet-stream",
    }
}

/// Serve `routes` on `listener` until the process ends.
pub fn serve(listener: TcpListener, routes: Vec<Route>) {
    let routes: Arc<[Route]> = routes.into();
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        let routes = Arc::clone(&routes);
        std::thread::spawn(move || {
            // A client that goes away mid-answer is not an error of the viewer.
            let _ = handle(stream, &routes);
        });
    }
}

/// Answer the requests of one connection (kept alive until the client closes it).
fn handle(stream: TcpStream, routes: &[Route]) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(30)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut out = stream;
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line)? == 0 {
            return Ok(());
        }
        let mut parts = line.split_whitespace();
        let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("/"));
        let mut range = None;
        let mut close = false;
        let mut websocket_key = None;
        let mut upgrade = false;
        let mut origin = None;
        loop {
            let mut header = String::new();
            if reader.read_line(&mut header)? == 0 {
                return Ok(());
            }
            let header = header.trim_end();
            if header.is_empty() {
                break;
            }
            if let Some((name, value)) = header.split_once(':') {
                match name.trim().to_ascii_lowercase().as_str() {
                    "range" => range = Some(value.trim().to_string()),
                    "connection" => close = value.trim().eq_ignore_ascii_case("close"),
                    "sec-websocket-key" => websocket_key = Some(value.trim().to_string()),
                    "upgrade" => upgrade = value.trim().eq_ignore_ascii_case("websocket"),
                    "origin" => origin = Some(value.trim().to_string()),
                    _ => {}
                }
            }
        }
        let path = target.split(['?', '#']).next().unwrap_or("/");
        if method != "GET" && method != "HEAD" {
            respond(&mut out, "405 Method Not Allowed", "text/plain", b"GET or HEAD only\n", method == "HEAD", &[])?;
        } else {
            match routes.iter().find(|r| r.path == path) {
                None => respond(&mut out, "404 Not Found", "text/plain", b"not found\n", method == "HEAD", &[])?,
                Some(Route { body: Body::Socket(handler), .. }) => {
                    let (Some(key), true, "GET") = (websocket_key, upgrade, method) else {
                        let text = b"a WebSocket: connect with new WebSocket(...)\n";
                        let extra = [("Upgrade", "websocket".to_string()), ("Sec-WebSocket-Version", "13".into())];
                        return respond(&mut out, "426 Upgrade Required", "text/plain", text, method == "HEAD", &extra);
                    };
                    // Only the page this server serves may connect (not any site open in the
                    // same browser): its origin is this host, or none (a program).
                    let local = |o: &str| {
                        let host = o.strip_prefix("http://").unwrap_or("");
                        host.starts_with("127.0.0.1:") || host.starts_with("localhost:") || host.starts_with("[::1]:")
                    };
                    if origin.as_deref().is_some_and(|o| !local(o)) {
                        return respond(&mut out, "403 Forbidden", "text/plain", b"another site's page\n", false, &[]);
                    }
                    let accept = tungstenite::handshake::derive_accept_key(key.as_bytes());
                    write!(
                        out,
                        "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n\
                         Sec-WebSocket-Accept: {accept}\r\n\r\n"
                    )?;
                    out.flush()?;
                    out.set_read_timeout(None)?;
                    handler.serve(out);
                    return Ok(());
                }
                Some(route) => send(&mut out, route, range.as_deref(), method == "HEAD")?,
            }
        }
        out.flush()?;
        if close {
            return Ok(());
        }
    }
}

/// Send a route's body, or the byte range asked for.
fn send(out: &mut TcpStream, route: &Route, range: Option<&str>, head: bool) -> std::io::Result<()> {
    let len = match &route.body {
        Body::Bytes(b) => b.len() as u64,
        Body::File(p) => std::fs::metadata(p)?.len(),
        Body::Socket(_) => 0,
    };
    let (status, start, end) = match range.and_then(|r| parse_range(r, len)) {
        Some((a, b)) => ("206 Partial Content", a, b),
        None if range.is_some() && len > 0 => {
            let extra = [("Content-Range", format!("bytes */{len}"))];
            return respond(out, "416 Range Not Satisfiable", "text/plain", b"", head, &extra);
        }
        None => ("200 OK", 0, len),
    };
    let mut headers = vec![("Accept-Ranges", "bytes".to_string())];
    if status.starts_with("206") {
        headers.push(("Content-Range", format!("bytes {start}-{}/{len}", end.saturating_sub(1))));
    }
    write!(
        out,
        "HTTP/1.1 {status}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n",
        route.content_type,
        end - start
    )?;
    for (k, v) in headers {
        write!(out, "{k}: {v}\r\n")?;
    }
    out.write_all(b"\r\n")?;
    if head {
        return Ok(());
    }
    match &route.body {
        Body::Bytes(b) => out.write_all(&b[start as usize..end as usize]),
        Body::File(p) => {
            let mut f = std::fs::File::open(p)?;
            f.seek(SeekFrom::Start(start))?;
            std::io::copy(&mut f.take(end - start), out).map(|_| ())
        }
        Body::Socket(_) => Ok(()),
    }
}

fn respond(
    out: &mut TcpStream,
    status: &str,
    content_type: &str,
    body: &[u8],
    head: bool,
    extra: &[(&str, String)],
) -> std::io::Result<()> {
    write!(out, "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\n", body.len())?;
    for (k, v) in extra {
        write!(out, "{k}: {v}\r\n")?;
    }
    out.write_all(b"\r\n")?;
    if !head {
        out.write_all(body)?;
    }
    Ok(())
}

/// A single `bytes=a-b`, `bytes=a-` or `bytes=-n` range of a body of `len` bytes, as a
/// half-open interval; None when it cannot be satisfied (or is not one range).
fn parse_range(spec: &str, len: u64) -> Option<(u64, u64)> {
    let spec = spec.strip_prefix("bytes=")?;
    if spec.contains(',') {
        return None;
    }
    let (a, b) = spec.split_once('-')?;
    let (a, b) = (a.trim(), b.trim());
    let (start, end) = if a.is_empty() {
        let n: u64 = b.parse().ok()?;
        (len.saturating_sub(n), len)
    } else {
        let start: u64 = a.parse().ok()?;
        let end = if b.is_empty() { len } else { (b.parse::<u64>().ok()? + 1).min(len) };
        (start, end)
    };
    (start < end && start < len).then_some((start, end))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges() {
        assert_eq!(parse_range("bytes=0-", 100), Some((0, 100)));
        assert_eq!(parse_range("bytes=10-19", 100), Some((10, 20)));
        assert_eq!(parse_range("bytes=90-200", 100), Some((90, 100)));
        assert_eq!(parse_range("bytes=-10", 100), Some((90, 100)));
        assert_eq!(parse_range("bytes=100-", 100), None);
        assert_eq!(parse_range("bytes=0-1,5-6", 100), None);
        assert_eq!(parse_range("items=0-1", 100), None);
    }

    #[test]
    fn serves_a_file_in_ranges_over_real_tcp() {
        let dir = std::env::temp_dir().join(format!("drumsim-http-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("a.wav");
        std::fs::write(&file, (0..=255u8).collect::<Vec<u8>>()).unwrap();
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let routes = vec![Route { path: "/a.wav".into(), content_type: "audio/wav", body: Body::File(file) }];
        std::thread::spawn(move || serve(listener, routes));
        let get = |request: &str| {
            let mut s = TcpStream::connect(addr).unwrap();
            s.write_all(request.as_bytes()).unwrap();
            let mut answer = Vec::new();
            s.read_to_end(&mut answer).unwrap();
            answer
        };
        let answer = get("GET /a.wav HTTP/1.1\r\nRange: bytes=16-31\r\nConnection: close\r\n\r\n");
        let text = String::from_utf8_lossy(&answer);
        assert!(text.starts_with("HTTP/1.1 206"), "{text}");
        assert!(text.contains("Content-Range: bytes 16-31/256"), "{text}");
        assert_eq!(&answer[answer.len() - 16..], &(16..32u8).collect::<Vec<u8>>()[..]);
        let answer = get("GET /nothing HTTP/1.1\r\nConnection: close\r\n\r\n");
        assert!(String::from_utf8_lossy(&answer).starts_with("HTTP/1.1 404"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
