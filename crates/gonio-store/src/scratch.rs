//! A throw-away PostgreSQL server for tests: a fresh cluster (`initdb`) in a temporary
//! directory, listening only on a Unix socket there, stopped and deleted when dropped. Uses the
//! Debian `postgresql` package's programs (found on `PATH` or under `/usr/lib/postgresql/*/bin`).
//! PostgreSQL refuses to run as root, so under root the server runs as the unprivileged user
//! `nobody` (through `runuser`).
//!
//! Nothing is skipped silently: [`ScratchServer::start`] returns an error saying what is missing
//! or what failed (with the server's log).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A running throw-away server.
#[derive(Debug)]
pub struct ScratchServer {
    dir: tempfile::TempDir,
    bin: PathBuf,
    as_user: Option<String>,
    url: String,
}

fn bin_dir() -> Result<PathBuf, String> {
    let on_path = std::env::var_os("PATH")
        .map(|p| std::env::split_paths(&p).collect::<Vec<_>>())
        .unwrap_or_default();
    for d in &on_path {
        if d.join("initdb").is_file() && d.join("pg_ctl").is_file() {
            return Ok(d.clone());
        }
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir("/usr/lib/postgresql")
        .map(|r| {
            r.filter_map(|e| e.ok().map(|e| e.path().join("bin")))
                .collect()
        })
        .unwrap_or_default();
    found.retain(|d| d.join("initdb").is_file());
    found.sort_by_key(|d| {
        d.parent()
            .and_then(|v| v.file_name())
            .and_then(|v| v.to_str())
            .and_then(|v| v.parse::<u32>().ok())
            .unwrap_or(0)
    });
    found.pop().ok_or_else(|| {
        "PostgreSQL's initdb and pg_ctl not found (on PATH or in /usr/lib/postgresql/*/bin): install the Debian package postgresql (.ci/run does)".to_string()
    })
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn euid() -> Option<u32> {
    let o = Command::new("id").arg("-u").output().ok()?;
    String::from_utf8_lossy(&o.stdout).trim().parse().ok()
}

fn ids_of(user: &str) -> Result<(u32, u32), String> {
    let get = |flag: &str| -> Result<u32, String> {
        let o = Command::new("id")
            .args([flag, user])
            .output()
            .map_err(|e| format!("id {flag} {user}: {e}"))?;
        String::from_utf8_lossy(&o.stdout)
            .trim()
            .parse()
            .map_err(|_| format!("no user {user}: {}", text(&o)))
    };
    Ok((get("-u")?, get("-g")?))
}

impl ScratchServer {
    /// Creates a cluster in a new temporary directory and starts it.
    ///
    /// # Errors
    /// A one-paragraph reason: the programs are missing, `initdb` or `pg_ctl start` failed (with
    /// the server's log).
    pub fn start() -> Result<ScratchServer, String> {
        let bin = bin_dir()?;
        let as_user = if euid() == Some(0) {
            Some("nobody".to_string())
        } else {
            None
        };
        let dir = tempfile::Builder::new()
            .prefix("gonio-pg-")
            .tempdir_in("/tmp")
            .map_err(|e| format!("temporary directory: {e}"))?;
        if let Some(u) = &as_user {
            let (uid, gid) = ids_of(u)?;
            std::os::unix::fs::chown(dir.path(), Some(uid), Some(gid))
                .map_err(|e| format!("chown {} to {u}: {e}", dir.path().display()))?;
        }
        let mut s = ScratchServer {
            dir,
            bin,
            as_user,
            url: String::new(),
        };
        let data = s.dir.path().join("data");
        let o = s.run(
            "initdb",
            &[
                "-D",
                &data.display().to_string(),
                "-A",
                "trust",
                "-U",
                "gonio",
                "-E",
                "UTF8",
                "--no-sync",
            ],
        )?;
        if !o.status.success() {
            return Err(format!("initdb failed: {}", text(&o)));
        }
        let sock = s.dir.path().display().to_string();
        let log = s.dir.path().join("server.log");
        let opts =
            format!("-k {sock} -c listen_addresses='' -p 5432 -c fsync=off -c max_connections=40");
        let o = s.run(
            "pg_ctl",
            &[
                "-D",
                &data.display().to_string(),
                "-o",
                &opts,
                "-l",
                &log.display().to_string(),
                "-w",
                "-t",
                "60",
                "start",
            ],
        )?;
        if !o.status.success() {
            let l = std::fs::read_to_string(&log).unwrap_or_default();
            return Err(format!("pg_ctl start failed: {} {l}", text(&o)));
        }
        let url = format!("postgres://gonio@localhost/postgres?host={sock}&port=5432");
        s.url = url;
        Ok(s)
    }

    fn run(&self, prog: &str, args: &[&str]) -> Result<Output, String> {
        let exe = self.bin.join(prog);
        let mut c = match &self.as_user {
            Some(u) => {
                let mut c = Command::new("runuser");
                c.args(["-u", u, "--"]).arg(&exe);
                c
            }
            None => Command::new(&exe),
        };
        c.args(args)
            .current_dir(self.dir.path())
            .output()
            .map_err(|e| format!("cannot run {}: {e}", exe.display()))
    }

    /// The URL of the server's `postgres` database (user `gonio`, trusted on the socket).
    pub fn url(&self) -> &str {
        &self.url
    }

    /// A new empty database on the server; returns its URL.
    ///
    /// # Errors
    /// The server's message when the database cannot be created.
    pub fn create_database(&self, name: &str) -> Result<String, String> {
        let mut c = postgres::Client::connect(&self.url, postgres::NoTls)
            .map_err(|e| format!("connect {}: {e}", self.url))?;
        c.batch_execute(&format!("CREATE DATABASE {name}"))
            .map_err(|e| format!("CREATE DATABASE {name}: {e}"))?;
        Ok(self.url.replacen("/postgres?", &format!("/{name}?"), 1))
    }

    /// The directory holding the cluster and its socket.
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }
}

impl Drop for ScratchServer {
    fn drop(&mut self) {
        if !self.url.is_empty() {
            let data = self.dir.path().join("data").display().to_string();
            let _ = self.run("pg_ctl", &["-D", &data, "-m", "immediate", "-w", "stop"]);
        }
    }
}
