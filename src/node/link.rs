//! A node's links to its peers (docs/real-network.md): authenticated, length-prefixed frames
//! over TCP, one listener for the links peers open and one writer per peer.
//!
//! Every peer link is authenticated: the dialing node sends `Hello` (cluster name, both ids, a
//! fresh nonce); the listening node answers with its own nonce and an HMAC-SHA256 over the
//! transcript under the cluster key; the dialer answers with its HMAC. Both then derive a
//! session key from the transcript, and every frame (a sequence number, the layer and the
//! message's wire encoding) carries an HMAC under it, with sequence numbers strictly
//! increasing, so a captured frame replayed on this or another connection is refused. Frames
//! are length-prefixed and limited to [`MAX_FRAME`] bytes. A connection that breaks any rule
//! is logged in one line and closed; the protocol state is untouched.

use std::collections::HashMap;
use std::io;
use std::net::SocketAddr;
use std::rc::Rc;
use std::time::{Duration, SystemTime};

use hmac::{Hmac, Mac};
use serde::{Deserialize, Serialize};
use sha2::Sha256;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::mpsc;
use tokio::task::JoinHandle;

type HmacSha256 = Hmac<Sha256>;

/// The wire protocol's version; a peer of another version is refused.
pub const VERSION: u16 = 1;
/// The largest frame accepted [bytes].
pub const MAX_FRAME: u32 = 1 << 20;
/// The first bytes of a `Hello`.
pub const MAGIC: [u8; 4] = *b"NEKO";
/// How long a handshake may take.
const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(5);
/// How long a writer may go on sending what it holds once the node stops.
const DRAIN: Duration = Duration::from_secs(2);

/// The dialer's first message.
#[derive(Debug, Serialize, Deserialize)]
pub struct Hello {
    pub magic: [u8; 4],
    pub version: u16,
    pub cluster: String,
    pub from: u32,
    pub to: u32,
    pub nonce: [u8; 16],
}

/// The listener's answer: its nonce and its proof of the key.
#[derive(Debug, Serialize, Deserialize)]
pub struct Challenge {
    pub nonce: [u8; 16],
    pub mac: [u8; 32],
}

/// The dialer's proof of the key.
#[derive(Debug, Serialize, Deserialize)]
pub struct Auth {
    pub mac: [u8; 32],
}

/// A message on an authenticated link: `tag` is the HMAC of `(seq, layer, bytes)` under the
/// session key.
#[derive(Debug, Serialize, Deserialize)]
pub struct Frame {
    pub seq: u64,
    pub layer: u16,
    pub bytes: Vec<u8>,
    pub tag: [u8; 32],
}

/// HMAC-SHA256 of `parts`, each prefixed by its length.
fn mac(key: &[u8], parts: &[&[u8]]) -> HmacSha256 {
    let mut m = HmacSha256::new_from_slice(key).expect("HMAC takes keys of any length");
    for p in parts {
        m.update(&(p.len() as u64).to_le_bytes());
        m.update(p);
    }
    m
}

/// HMAC-SHA256 of `parts` under `key`, each part prefixed by its length: how handshakes and
/// frames are signed.
pub fn tag(key: &[u8], parts: &[&[u8]]) -> [u8; 32] {
    mac(key, parts).finalize().into_bytes().into()
}

/// Constant-time check of `expected` against the HMAC of `parts`.
fn verify(key: &[u8], parts: &[&[u8]], expected: &[u8]) -> bool {
    mac(key, parts).verify_slice(expected).is_ok()
}

/// The handshake transcript: what both sides sign.
struct Transcript<'a> {
    cluster: &'a str,
    from: [u8; 4],
    to: [u8; 4],
    nonce_c: [u8; 16],
    nonce_s: [u8; 16],
}

impl Transcript<'_> {
    fn parts<'p>(&'p self, label: &'p [u8]) -> [&'p [u8]; 6] {
        [
            label,
            self.cluster.as_bytes(),
            &self.from,
            &self.to,
            &self.nonce_c,
            &self.nonce_s,
        ]
    }
}

fn bad(message: impl Into<String>) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, message.into())
}

async fn read_msg(s: &mut TcpStream) -> io::Result<Vec<u8>> {
    let len = s.read_u32().await?;
    if len > MAX_FRAME {
        return Err(bad(format!(
            "a frame of {len} bytes, over the {MAX_FRAME}-byte limit"
        )));
    }
    let mut buf = vec![0; len as usize];
    s.read_exact(&mut buf).await?;
    Ok(buf)
}

async fn write_msg(s: &mut TcpStream, bytes: &[u8]) -> io::Result<()> {
    s.write_u32(bytes.len() as u32).await?;
    s.write_all(bytes).await
}

fn decode<T: for<'de> Deserialize<'de>>(bytes: &[u8], what: &str) -> io::Result<T> {
    nekosim_protocols::payload::decode_bytes(bytes)
        .map_err(|e| bad(format!("a {what} that does not decode ({e})")))
}

fn nonce() -> [u8; 16] {
    rand::random()
}

/// The dialer's side: proves the key, checks the listener's proof; the session key.
async fn dial_handshake(
    s: &mut TcpStream,
    key: &[u8],
    cluster: &str,
    me: u32,
    peer: u32,
) -> io::Result<Vec<u8>> {
    let hello = Hello {
        magic: MAGIC,
        version: VERSION,
        cluster: cluster.to_string(),
        from: me,
        to: peer,
        nonce: nonce(),
    };
    write_msg(
        s,
        &postcard::to_allocvec(&hello).map_err(|e| bad(e.to_string()))?,
    )
    .await?;
    let ch: Challenge = decode(&read_msg(s).await?, "challenge")?;
    let t = Transcript {
        cluster,
        from: me.to_le_bytes(),
        to: peer.to_le_bytes(),
        nonce_c: hello.nonce,
        nonce_s: ch.nonce,
    };
    if !verify(key, &t.parts(b"nekosim accept"), &ch.mac) {
        return Err(bad("the peer does not know the cluster key"));
    }
    let auth = Auth {
        mac: tag(key, &t.parts(b"nekosim dial")),
    };
    write_msg(
        s,
        &postcard::to_allocvec(&auth).map_err(|e| bad(e.to_string()))?,
    )
    .await?;
    Ok(tag(key, &t.parts(b"nekosim session")).to_vec())
}

/// The listener's side: the peer's id and the session key, or why the peer is refused.
async fn accept_handshake(
    s: &mut TcpStream,
    key: &[u8],
    cluster: &str,
    me: u32,
    n: u32,
) -> io::Result<(u32, Vec<u8>)> {
    let hello: Hello = decode(&read_msg(s).await?, "hello")?;
    if hello.magic != MAGIC {
        return Err(bad("not a nekosim peer"));
    }
    if hello.version != VERSION {
        return Err(bad(format!(
            "version mismatch: the peer speaks version {}, this node {VERSION}",
            hello.version
        )));
    }
    if hello.cluster != cluster || hello.to != me || hello.from >= n || hello.from == me {
        return Err(bad(format!(
            "unknown peer: node {} of cluster {:?} (to node {})",
            hello.from, hello.cluster, hello.to
        )));
    }
    let t = Transcript {
        cluster,
        from: hello.from.to_le_bytes(),
        to: me.to_le_bytes(),
        nonce_c: hello.nonce,
        nonce_s: nonce(),
    };
    let ch = Challenge {
        nonce: t.nonce_s,
        mac: tag(key, &t.parts(b"nekosim accept")),
    };
    write_msg(
        s,
        &postcard::to_allocvec(&ch).map_err(|e| bad(e.to_string()))?,
    )
    .await?;
    let auth: Auth = decode(&read_msg(s).await?, "authentication")?;
    if !verify(key, &t.parts(b"nekosim dial"), &auth.mac) {
        return Err(bad(format!(
            "failed handshake: node {} does not know the cluster key",
            hello.from
        )));
    }
    Ok((hello.from, tag(key, &t.parts(b"nekosim session")).to_vec()))
}

/// Whether now falls in one of `cuts` (seconds since `start`).
fn in_cut(cuts: &[(f64, f64)], start: SystemTime) -> bool {
    if cuts.is_empty() {
        return false;
    }
    let t = SystemTime::now()
        .duration_since(start)
        .unwrap_or_default()
        .as_secs_f64();
    cuts.iter().any(|(a, b)| *a <= t && t < *b)
}

/// What every link of a node shares.
pub(super) struct Peers {
    /// The cluster's name.
    pub cluster: String,
    pub key: Vec<u8>,
    /// This node's id.
    pub me: u32,
    /// Node `i`'s address.
    pub addrs: Vec<SocketAddr>,
    /// When the link to node `i` is cut [s since `clock`].
    pub cuts: Vec<Vec<(f64, f64)>>,
    /// The cluster's start.
    pub clock: SystemTime,
}

impl Peers {
    fn cut(&self, peer: u32) -> bool {
        self.cuts
            .get(peer as usize)
            .is_some_and(|c| in_cut(c, self.clock))
    }
}

/// A message that arrived on an authenticated link, for layer `layer`.
#[derive(Debug)]
pub struct Arrival {
    pub from: u32,
    pub layer: u16,
    pub bytes: Vec<u8>,
}

/// Accepts the links peers open, for as long as the node runs: every authenticated frame
/// that arrives while its link is not cut goes to `tx`.
pub(super) fn listen<E: From<Arrival> + 'static>(
    listener: TcpListener,
    peers: Rc<Peers>,
    tx: mpsc::UnboundedSender<E>,
) {
    actix::spawn(async move {
        loop {
            let Ok((s, from_addr)) = listener.accept().await else {
                continue;
            };
            let (peers, tx) = (peers.clone(), tx.clone());
            actix::spawn(async move {
                if let Err(e) = receive(s, &peers, &tx).await {
                    if e.kind() != io::ErrorKind::UnexpectedEof {
                        eprintln!(
                            "node {}: connection from {from_addr}: {e}; closed",
                            peers.me
                        );
                    }
                }
            });
        }
    });
}

/// One incoming link: the handshake, then frames in sequence until the peer closes it or
/// breaks a rule.
async fn receive<E: From<Arrival>>(
    mut s: TcpStream,
    peers: &Peers,
    tx: &mpsc::UnboundedSender<E>,
) -> io::Result<()> {
    let n = peers.addrs.len() as u32;
    let (peer, session) = tokio::time::timeout(
        HANDSHAKE_TIMEOUT,
        accept_handshake(&mut s, &peers.key, &peers.cluster, peers.me, n),
    )
    .await
    .map_err(|_| bad("handshake timed out"))??;
    let mut next = 0u64;
    loop {
        let f: Frame = decode(&read_msg(&mut s).await?, "frame")?;
        let ok = verify(
            &session,
            &[&f.seq.to_le_bytes(), &f.layer.to_le_bytes(), &f.bytes],
            &f.tag,
        );
        if !ok {
            return Err(bad(format!(
                "node {peer}: a frame that fails authentication"
            )));
        }
        if f.seq != next {
            return Err(bad(format!(
                "node {peer}: frame {} out of sequence (expected {next}): a replay",
                f.seq
            )));
        }
        next += 1;
        if peers.cut(peer) {
            continue;
        }
        let arrival = Arrival {
            from: peer,
            layer: f.layer,
            bytes: f.bytes,
        };
        if tx.send(arrival.into()).is_err() {
            return Ok(());
        }
    }
}

/// The node's outgoing links: one writer per peer, which dials, reconnects with backoff and
/// sends what the node hands it, in order.
pub(super) struct Links {
    senders: HashMap<u32, mpsc::UnboundedSender<(u16, Vec<u8>)>>,
    writers: Vec<JoinHandle<()>>,
}

impl Links {
    /// Starts a writer for every peer.
    pub(super) fn dial(peers: &Rc<Peers>) -> Self {
        let mut links = Links {
            senders: HashMap::new(),
            writers: Vec::new(),
        };
        for (peer, &addr) in peers.addrs.iter().enumerate() {
            let peer = peer as u32;
            if peer == peers.me {
                continue;
            }
            let (tx, rx) = mpsc::unbounded_channel();
            links.senders.insert(peer, tx);
            links
                .writers
                .push(actix::spawn(write(peers.clone(), peer, addr, rx)));
        }
        links
    }

    /// Hands `bytes` for layer `layer` to the writer of `peer`.
    pub(super) fn send(&self, peer: u32, layer: u16, bytes: Vec<u8>) {
        if let Some(l) = self.senders.get(&peer) {
            let _ = l.send((layer, bytes));
        }
    }

    /// Closes every link; with `drain`, first lets the writers send what they hold, briefly.
    pub(super) async fn close(self, drain: bool) {
        drop(self.senders);
        if drain {
            for w in self.writers {
                let _ = tokio::time::timeout(DRAIN, w).await;
            }
        }
    }
}

/// The writer of the link to `peer` at `addr`.
async fn write(
    peers: Rc<Peers>,
    peer: u32,
    addr: SocketAddr,
    mut rx: mpsc::UnboundedReceiver<(u16, Vec<u8>)>,
) {
    let me = peers.me;
    let mut pending: Option<(u16, Vec<u8>)> = None;
    let mut backoff = Duration::from_millis(20);
    loop {
        let connected = async {
            let mut s = TcpStream::connect(addr).await?;
            s.set_nodelay(true)?;
            let session = tokio::time::timeout(
                HANDSHAKE_TIMEOUT,
                dial_handshake(&mut s, &peers.key, &peers.cluster, me, peer),
            )
            .await
            .map_err(|_| bad("handshake timed out"))??;
            Ok::<_, io::Error>((s, session))
        }
        .await;
        let (mut s, session) = match connected {
            Ok(c) => c,
            Err(e) => {
                if e.kind() == io::ErrorKind::InvalidData {
                    eprintln!("node {me}: link to node {peer}: {e}");
                }
                if pending.is_none() && rx.is_closed() && rx.is_empty() {
                    return;
                }
                tokio::time::sleep(backoff).await;
                backoff = (backoff * 2).min(Duration::from_secs(1));
                continue;
            }
        };
        backoff = Duration::from_millis(20);
        let mut seq = 0u64;
        loop {
            let next = match pending.take() {
                Some(m) => Some(m),
                None => rx.recv().await,
            };
            let Some((layer, bytes)) = next else {
                let _ = s.shutdown().await;
                return;
            };
            if peers.cut(peer) {
                // The link is cut: the frame is lost.
                continue;
            }
            let frame = Frame {
                seq,
                layer,
                tag: tag(
                    &session,
                    &[&seq.to_le_bytes(), &layer.to_le_bytes(), &bytes],
                ),
                bytes,
            };
            let buf = postcard::to_allocvec(&frame).expect("frames encode");
            if write_msg(&mut s, &buf).await.is_err() {
                // Sent again on the next connection.
                pending = Some((frame.layer, frame.bytes));
                break;
            }
            seq += 1;
        }
    }
}
