//! A minimal Foxglove WebSocket client for measuring the live view: connects to
//! ADDR (default 127.0.0.1:8765, retrying for 30 s), subscribes to every advertised
//! topic, and counts what arrives until the server closes; then prints the counts.
//!
//! `cargo run --release -p mmq-log --example live_client -- 127.0.0.1:8765`

use std::collections::HashMap;
use std::net::TcpStream;
use std::time::{Duration, Instant};

use tungstenite::Message;
use tungstenite::client::IntoClientRequest;

fn main() {
    let addr = std::env::args().nth(1).unwrap_or_else(|| "127.0.0.1:8765".into());
    let deadline = Instant::now() + Duration::from_secs(30);
    let stream = loop {
        match TcpStream::connect(&addr) {
            Ok(s) => break s,
            Err(e) if Instant::now() < deadline => {
                let _ = e;
                std::thread::sleep(Duration::from_millis(20));
            }
            Err(e) => {
                eprintln!("live_client: cannot connect to {addr}: {e}");
                std::process::exit(1);
            }
        }
    };
    let mut req = format!("ws://{addr}").into_client_request().expect("a request");
    req.headers_mut().insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().expect("a header"));
    let (mut ws, _) = tungstenite::client::client(req, stream).expect("a WebSocket handshake");
    let t0 = Instant::now();
    let mut topics: HashMap<u32, String> = HashMap::new();
    let mut counts: HashMap<String, u64> = HashMap::new();
    let (mut bytes, mut times) = (0u64, 0u64);
    while let Ok(m) = ws.read() {
        match m {
            Message::Text(t) => {
                let v: serde_json::Value = serde_json::from_str(&t).expect("JSON");
                if v["op"] == "advertise" {
                    let mut subs = Vec::new();
                    for ch in v["channels"].as_array().expect("channels") {
                        let id = topics.len() as u32 + 1;
                        topics.insert(id, ch["topic"].as_str().unwrap_or("?").to_string());
                        subs.push(serde_json::json!({"id": id, "channelId": ch["id"]}));
                    }
                    let msg = serde_json::json!({"op": "subscribe", "subscriptions": subs});
                    ws.send(Message::Text(msg.to_string().into())).expect("subscribe");
                }
            }
            Message::Binary(b) if b.first() == Some(&1) && b.len() >= 13 => {
                let sub = u32::from_le_bytes(b[1..5].try_into().expect("4 bytes"));
                *counts.entry(topics.get(&sub).cloned().unwrap_or_default()).or_insert(0) += 1;
                bytes += b.len() as u64 - 13;
            }
            Message::Binary(b) if b.first() == Some(&2) => times += 1,
            Message::Close(_) => break,
            _ => {}
        }
    }
    let mut counts: Vec<_> = counts.into_iter().collect();
    counts.sort();
    for (t, n) in &counts {
        println!("{t:<24} {n:>9}");
    }
    println!(
        "{} messages ({bytes} bytes of JSON), {times} time updates in {:.2} s",
        counts.iter().map(|(_, n)| n).sum::<u64>(),
        t0.elapsed().as_secs_f64()
    );
}
