"""An MES that gonio did not write: the Python `asyncua` client (PyPI) against `gonio serve
--opcua`. Run by crates/gonio-cli/tests/opcua_asyncua.rs in its own virtualenv; each mode starts
its `gonio serve` itself (after asyncua is imported, so the client is ready before the first
part ends), checks, and stops it. Prints "all checks passed" at the end.

    python mes_check.py GONIO MODE DB WORKDIR

MODE: batch (a simulated batch: events, results, monitoring, read-only), security (users,
policies, certificates), robust (50 clients, garbage bytes, a client killed mid-subscription),
offloop (inside a network namespace with 192.0.2.1: no None, no anonymous), load (50
subscribed clients against none: the batch's time, printed for BENCHMARKS.md).
"""

import asyncio
import json
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import time
import logging
from pathlib import Path

from asyncua import Client, ua
from asyncua.common.events import get_filter_from_event_type
from asyncua.crypto import security_policies
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from cryptography.x509.oid import ExtendedKeyUsageOID

logging.basicConfig(level=logging.CRITICAL)

GONIO, MODE, DB, WORK = sys.argv[1], sys.argv[2], sys.argv[3], Path(sys.argv[4])
RESULT_NS = "http://opcfoundation.org/UA/Machinery/Result/"
MACHINERY_NS = "http://opcfoundation.org/UA/Machinery/"
DI_NS = "http://opcfoundation.org/UA/DI/"
GONIO_NS = "urn:gonio:ua:station"


def fail(msg):
    raise SystemExit(f"FAILED: {msg}")


def check(cond, msg):
    if not cond:
        fail(msg)


class Serve:
    """`gonio serve` in the background; the OPC UA URL from its 'OPC UA on' line."""

    def __init__(self, args, host="127.0.0.1"):
        # At the normal priority, whatever this script's own (the load mode lowers it).
        self.p = subprocess.Popen(
            [GONIO, "serve", "--addr", f"{host}:0", *args],
            preexec_fn=lambda: os.setpriority(os.PRIO_PROCESS, 0, 0) if os.geteuid() == 0 else None,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines = []
        self.url = None
        self.stopping_on_error = False
        deadline = time.time() + 60
        while time.time() < deadline:
            line = self.p.stderr.readline()
            if not line:
                break
            self.lines.append(line.rstrip())
            if line.startswith("OPC UA on "):
                self.url = line.split("OPC UA on ", 1)[1].strip()
                break
        if self.url is None:
            self.stopping_on_error = True
            self.stop()
            fail(f"gonio serve {' '.join(args)} printed no 'OPC UA on': {self.lines}")
        self.loop = asyncio.get_event_loop()
        self.reader = self.loop.run_in_executor(None, self._drain)

    def _drain(self):
        for line in self.p.stderr:
            self.lines.append(line.rstrip())

    async def wait_for(self, text, limit=120):
        deadline = time.time() + limit
        while time.time() < deadline:
            if any(text in l for l in self.lines):
                return
            if self.p.poll() is not None:
                break
            await asyncio.sleep(0.05)
        fail(f"no line with {text!r} from gonio serve: {self.lines}")

    def alive(self):
        return self.p.poll() is None

    def stop(self):
        """Ctrl-C; it must end by itself, with exit code 0 (a clean stop)."""
        if self.p.poll() is None:
            self.p.send_signal(signal.SIGINT)
            try:
                self.p.wait(15)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
                fail(f"gonio serve did not stop within 15 s of Ctrl-C: {self.lines}")
        # While another failure is on its way out, that one is the message.
        if self.p.returncode != 0 and not self.stopping_on_error and sys.exc_info()[0] is None:
            fail(f"gonio serve ended with {self.p.returncode}: {self.lines}")


def store_parts(db):
    out = subprocess.run([GONIO, "parts", "--db", db, "--json"], capture_output=True, text=True)
    check(out.returncode == 0, f"gonio parts: {out.stderr}")
    return json.loads(out.stdout)


def final_turn(p):
    """The store's last trusted turn, when it gave the final e."""
    trusted = [t for t in p["turns"] if (t.get("quality") or {}).get("ok")]
    if trusted and trusted[-1]["e_um"] is not None and trusted[-1]["e_um"] == p["final_e_um"]:
        return trusted[-1]
    return None


def check_result(r, p, what):
    """A ResultDataType against the store's record `p`, number for number."""
    m = r.ResultMetaData
    check(m.ResultId == f"{p['station']}/{p['part']}", f"{what}: ResultId {m.ResultId}")
    check(m.PartId == p["serial"], f"{what}: PartId {m.PartId} != {p['serial']}")
    check(m.ProductId == p["recipe"], f"{what}: ProductId {m.ProductId}")
    check(m.InternalRecipeId == p["recipe_hash"], f"{what}: InternalRecipeId")
    check(m.IsSimulated is (p["true_initial_e_um"] is not None), f"{what}: IsSimulated")
    want_state = 3 if p["device_error"] else 1
    check(m.ResultState == want_state, f"{what}: ResultState {m.ResultState}")
    want_eval = 1 if p["verdict"] == "pass" else 2
    check(int(m.ResultEvaluation) == want_eval, f"{what}: ResultEvaluation {m.ResultEvaluation}")
    check(m.CreationTime == m.ProcessingTimes.EndTime, f"{what}: CreationTime is the end")
    check(
        m.ProcessingTimes.StartTime.isoformat().replace("+00:00", "Z") == p["started_at"],
        f"{what}: StartTime {m.ProcessingTimes.StartTime} != {p['started_at']}",
    )
    check(
        m.ProcessingTimes.EndTime.isoformat().replace("+00:00", "Z") == p["ended_at"],
        f"{what}: EndTime {m.ProcessingTimes.EndTime} != {p['ended_at']}",
    )
    check(len(r.ResultContent) == 1, f"{what}: one content element")
    c = r.ResultContent[0].Value
    t = final_turn(p)
    for field, want in [
        ("StorePartId", p["part"]),
        ("Station", p["station"]),
        ("BatchId", p["batch"]),
        ("BatchIndex", p["batch_index"]),
        ("Strategy", p["strategy"]),
        ("InitialE_um", p["initial_e_um"]),
        ("FinalE_um", p["final_e_um"]),
        ("FinalU_um", t["u_e_um"] if t else None),
        ("FinalThetaMax_deg", t["theta_max_deg"] if t else None),
        ("Pushes", p["pushes"]),
        ("RemeasuredTurns", p["remeasured_turns"]),
        ("CycleTime_s", p["time_s"]),
        ("FocusTime_s", p["phase_times"]["focus_s"]),
        ("MeasureTime_s", p["phase_times"]["measure_s"]),
        ("PushTime_s", p["phase_times"]["push_s"]),
        ("Focus_um", p["focus_um"]),
        ("Verdict", p["verdict"]),
        ("Result", p["result"]),
        ("RejectReason", p["reject_reason"]),
        ("RecipeHash", p["recipe_hash"]),
        ("SoftwareVersion", p["software_version"]),
    ]:
        got = getattr(c, field)
        # Exactly the store's numbers: the same f64, not a rounding of it.
        check(got == want, f"{what}: {field} {got!r} != store {want!r}")


async def namespaces(c):
    ns = await c.get_namespace_array()
    return {u: ns.index(u) for u in (RESULT_NS, MACHINERY_NS, DI_NS, GONIO_NS)}


async def machine_nodes(c, station):
    ns = await namespaces(c)
    machine = await c.nodes.objects.get_child(
        [f"{ns[MACHINERY_NS]}:Machines", f"{ns[GONIO_NS]}:{station}"]
    )
    rm = await machine.get_child(f"{ns[RESULT_NS]}:ResultManagement")
    return ns, machine, rm


class Events:
    def __init__(self):
        self.events = []
        self.changes = []

    def event_notification(self, ev):
        self.events.append(ev)

    def datachange_notification(self, node, val, data):
        self.changes.append((node.nodeid.Identifier, val))


async def subscribe(c, station, period=100, of_type=False):
    """Events of ResultManagement and every Monitoring variable's changes. The events are
    selected by the event type's fields; ResultManagement sends only ResultReadyEventType,
    so no where clause is needed (async-opcua 0.19 compares only numbers in a where clause:
    asyncua's default, EventType InList [...], would match nothing; `of_type` asks with
    OfType instead, which it evaluates)."""
    ns, machine, rm = await machine_nodes(c, station)
    handler = Events()
    sub = await c.create_subscription(period, handler)
    evtype = c.get_node(ua.NodeId(1002, ns[RESULT_NS]))
    evfilter = await get_filter_from_event_type([evtype], where_clause_generation=False)
    if of_type:
        evfilter.WhereClause = ua.ContentFilter(Elements=[ua.ContentFilterElement(
            FilterOperator=ua.FilterOperator.OfType,
            FilterOperands=[ua.LiteralOperand(Value=ua.Variant(evtype.nodeid))])])
    # A queue for the events: the stack gives an item that asks for none a queue of one.
    await sub.subscribe_events(rm, evtype, evfilter=evfilter, queuesize=100)
    mon = await machine.get_child(f"{ns[MACHINERY_NS]}:Monitoring")
    await sub.subscribe_data_change(await mon.get_children())
    return handler, sub


async def call(rm, ns, name, *args):
    return await rm.call_method(f"{ns[RESULT_NS]}:{name}", *args)


def i32(v):
    return ua.Variant(v, ua.VariantType.Int32)


async def wait_events(h, n, serve, limit=120):
    deadline = time.time() + limit
    while len(h.events) < n and time.time() < deadline and serve.alive():
        await asyncio.sleep(0.05)
    check(len(h.events) >= n, f"{len(h.events)} ResultReady events of {n}: {serve.lines}")


async def batch():
    # A part of another station of the fleet, stored before the server starts.
    pre = subprocess.run(
        [GONIO, "mount", "--sim", "--parts", "1", "--seed", "9", "--db", DB,
         "--station-name", "line-2"],
        capture_output=True, text=True,
    )
    check(pre.returncode == 0, f"gonio mount: {pre.stderr}")
    serve = Serve(["--db", DB, "--station", "sim", "--parts", "3", "--seed", "1",
                   "--speed", "4", "--opcua", "127.0.0.1:0", "--opcua-anonymous"])
    try:
        c = Client(serve.url)
        async with c:
            await c.load_data_type_definitions()
            h, sub = await subscribe(c, "sim")
            h_of_type, _ = await subscribe(c, "sim", of_type=True)
            ns, machine, rm = await machine_nodes(c, "sim")
            # Identification (DI's names) and the address space's tree.
            ident = await machine.get_child(f"{ns[DI_NS]}:Identification")
            values = {}
            for name in ["Manufacturer", "Model", "SerialNumber", "SoftwareRevision",
                         "ProductInstanceUri"]:
                values[name] = await (await ident.get_child(f"{ns[DI_NS]}:{name}")).read_value()
            check(values["SerialNumber"] == "sim", f"SerialNumber {values}")
            check(values["ProductInstanceUri"] == "urn:gonio:station:sim", f"{values}")
            check(values["Manufacturer"].Text == "gonio", f"{values}")
            check(values["SoftwareRevision"], f"{values}")
            idtype = await ident.read_type_definition()
            check(idtype == ua.NodeId(1012, ns[MACHINERY_NS]), f"Identification type {idtype}")
            rmtype = await rm.read_type_definition()
            check(rmtype == ua.NodeId(1004, ns[RESULT_NS]), f"ResultManagement type {rmtype}")
            methods = {(await m.read_browse_name()).Name for m in await rm.get_methods()}
            check(methods == {"GetLatestResult", "GetResultById", "GetResultIdListFiltered",
                              "ReleaseResultHandle"}, f"methods {methods}")
            mon = await machine.get_child(f"{ns[MACHINERY_NS]}:Monitoring")
            names = {(await v.read_browse_name()).Name: v for v in await mon.get_children()}
            for n, unit in [("LastE_um", "µm"), ("LastU_um", "µm"), ("MeanCycleTime_s", "s"),
                            ("LinkRoundTripP50_ms", "ms")]:
                eu = await (await names[n].get_child("0:EngineeringUnits")).read_value()
                check(eu.DisplayName.Text == unit, f"{n}: unit {eu}")
            check(await names["StationMode"].read_value() == "sim", "StationMode")

            await wait_events(h, 3, serve)
            await serve.wait_for("batch done: 3 parts")
            await asyncio.sleep(0.5)
            parts = [p for p in store_parts(DB) if p["station"] == "sim"]
            check(len(parts) == 3, f"3 parts in the store, {len(parts)}")
            got = [e.Result.ResultMetaData.PartId for e in h.events]
            check(got == [p["serial"] for p in parts], f"event PartIds {got}")
            await wait_events(h_of_type, 3, serve, 5)
            check([e.Result.ResultMetaData.PartId for e in h_of_type.events] == got,
                  "the events selected with OfType")
            for e, p in zip(h.events, parts):
                check(e.EventType == ua.NodeId(1002, ns[RESULT_NS]), f"EventType {e.EventType}")
                check_result(e.Result, p, "event")
                check(getattr(e, "Result/ResultMetaData/PartId") == p["serial"],
                      "the event's Result/ResultMetaData/PartId field")

            # GetLatestResult: the last part, the store's numbers exactly.
            handle, result, error = await call(rm, ns, "GetLatestResult", i32(0))
            check(error == 0 and handle != 0, f"GetLatestResult error {error}, handle {handle}")
            check_result(result, parts[-1], "GetLatestResult")
            check(result.ResultContent[0].Value.FinalE_um == parts[-1]["final_e_um"],
                  "GetLatestResult's final e")
            # GetResultById: every part, and one stored before the server started, by
            # another station.
            for p in store_parts(DB):
                h2, r, err = await call(rm, ns, "GetResultById",
                                        ua.Variant(f"{p['station']}/{p['part']}", ua.VariantType.String), i32(-1))
                check(err == 0, f"GetResultById {p['station']}/{p['part']}: {err}")
                check_result(r, p, f"GetResultById {p['part']}")
            _, r, err = await call(rm, ns, "GetResultById", ua.Variant("sim/999", ua.VariantType.String), i32(0))
            check(err == -1 and (r is None or getattr(r, "Body", 1) is None), f"an unknown id: error {err}, {r}")
            _, r, err = await call(rm, ns, "GetResultById", ua.Variant("nonsense", ua.VariantType.String), i32(0))
            check(err == -4, f"a malformed id: error {err}")
            other = [p for p in store_parts(DB) if p["station"] == "line-2"][0]
            _, r, err = await call(rm, ns, "GetResultById", ua.Variant(f"sim/{other['part']}", ua.VariantType.String), i32(0))
            check(err == -1, "a part id with the wrong station is not found")
            # ReleaseResultHandle, once.
            check(await call(rm, ns, "ReleaseResultHandle", ua.Variant(handle, ua.VariantType.UInt32)) == 0, "release")
            check(await call(rm, ns, "ReleaseResultHandle", ua.Variant(handle, ua.VariantType.UInt32)) == -2, "release twice")
            # GetResultIdListFiltered: all of this station's, then by PartId.
            _, ids, err = await call(rm, ns, "GetResultIdListFiltered", ua.Variant(ua.ContentFilter()),
                                     ua.Variant([], ua.VariantType.ExtensionObject), ua.Variant(0, ua.VariantType.UInt32), i32(0))
            check(err == 0 and ids == [f"sim/{p['part']}" for p in parts], f"id list {ids} {err}")
            op = ua.SimpleAttributeOperand(
                TypeDefinitionId=ua.NodeId(2041),
                BrowsePath=[ua.QualifiedName("ResultMetaData", ns[RESULT_NS]),
                            ua.QualifiedName("PartId", ns[RESULT_NS])],
                AttributeId=ua.AttributeIds.Value)
            el = ua.ContentFilterElement(FilterOperator=ua.FilterOperator.Equals,
                                         FilterOperands=[op, ua.LiteralOperand(Value=ua.Variant(parts[1]["serial"]))])
            _, ids, err = await call(rm, ns, "GetResultIdListFiltered", ua.Variant(ua.ContentFilter(Elements=[el])),
                                     ua.Variant([], ua.VariantType.ExtensionObject), ua.Variant(0, ua.VariantType.UInt32), i32(0))
            check(err == 0 and ids == [f"sim/{parts[1]['part']}"], f"filtered {ids} {err}")
            _, ids, err = await call(rm, ns, "GetResultIdListFiltered", ua.Variant(ua.ContentFilter()),
                                     ua.Variant([], ua.VariantType.ExtensionObject), ua.Variant(2, ua.VariantType.UInt32), i32(0))
            check(ids == [f"sim/{p['part']}" for p in parts[1:]], f"MaxResults 2: {ids}")
            # The Results folder: the latest results, their values the results.
            results = await rm.get_child(f"{ns[RESULT_NS]}:Results")
            shown = {(await n.read_browse_name()).Name: n for n in await results.get_children()}
            check(set(shown) == {f"sim/{p['part']}" for p in parts}, f"Results folder {set(shown)}")
            check_result(await shown[f"sim/{parts[0]['part']}"].read_value(), parts[0], "Results")

            # Monitoring changed as the station ran.
            # A part's focus is carried from the last one with a short check (a fraction of a
            # second at 4x), shorter than the 100 ms sampling may catch, and the first part's
            # sweep may end before the client subscribes: the phases seen are the station's,
            # with its measuring turns and the end of the batch among them.
            phases = [v for k, v in h.changes if k.endswith("/Phase")]
            for ph in ["measure", "push", "verify", "idle"]:
                check(ph in phases, f"phase {ph} not seen: {phases}")
            check(set(phases) <= {"idle", "focus", "measure", "push", "verify"}, f"phases {phases}")
            done = [v for k, v in h.changes if k.endswith("/PartsDone")]
            check(done and done[-1] == 3, f"PartsDone {done}")
            serials = {v for k, v in h.changes if k.endswith("/CurrentPartSerial")}
            check({p["serial"] for p in parts} <= serials, f"CurrentPartSerial {serials}")
            es = [v for k, v in h.changes if k.endswith("/LastE_um") and v is not None]
            check(parts[-1]["final_e_um"] in es, f"LastE_um {es}")
            # Read-only: no write, no node added.
            try:
                await names["Phase"].write_value("push")
                fail("a write was accepted")
            except ua.UaStatusCodeError as e:
                check(e.code in (ua.StatusCodes.BadNotWritable, ua.StatusCodes.BadUserAccessDenied),
                      f"write refused with {e}")
            check(await names["Phase"].read_value() == "idle", "Phase unchanged")
            try:
                await machine.add_variable(ns[GONIO_NS], "Intruder", 1.0)
                fail("a node was added")
            except ua.UaStatusCodeError:
                pass
            await sub.delete()
        print(f"batch: 3 events, PartIds {got}, GetLatestResult final e {parts[-1]['final_e_um']} um")
    finally:
        serve.stop()


async def make_cert(name):
    cert, key = WORK / f"{name}.der", WORK / f"{name}.pem"
    uri = f"urn:gonio-test:{name}"
    await setup_self_signed_certificate(
        key, cert, uri, socket.gethostname(), [ExtendedKeyUsageOID.CLIENT_AUTH], {"commonName": name}
    )
    return cert, key, uri


def users_file(users):
    from argon2 import PasswordHasher

    ph = PasswordHasher(time_cost=1, memory_cost=8192, parallelism=1)
    path = WORK / "users.txt"
    path.write_text("# the line's MES\n" + "".join(f"{u}:{ph.hash(pw)}\n" for u, pw in users.items()))
    return path


async def secure_client(url, cert, key, uri, policy, user=None, password=None):
    c = Client(url)
    c.application_uri = uri
    await c.set_security(policy, str(cert), str(key), mode=ua.MessageSecurityMode.SignAndEncrypt)
    if user:
        c.set_user(user)
        c.set_password(password)
    return c


async def refused(c, what):
    try:
        async with c:
            pass
    except Exception:
        return
    fail(f"{what} was accepted")


async def security():
    pki = WORK / "pki"
    users = users_file({"mes": "s3cret-mes", "qa": "other"})
    cert, key, uri = await make_cert("mes-client")
    stranger = await make_cert("stranger")
    # The MES's certificate is trusted: put into trusted/ (under any name) before the start.
    (pki / "trusted").mkdir(parents=True, exist_ok=True)
    shutil.copy(cert, pki / "trusted" / cert.name)
    serve = Serve(["--db", DB, "--station-name", "line-2", "--opcua", "127.0.0.1:0",
                   "--opcua-users", str(users), "--opcua-pki", str(pki)])
    try:
        check((pki / "own/cert.der").exists() and (pki / "private/private.pem").exists(),
              "the certificate is generated into the PKI directory")
        # Only encrypted endpoints: no None without --opcua-anonymous.
        c = Client(serve.url)
        eps = await c.connect_and_get_server_endpoints()
        modes = {(e.SecurityPolicyUri.split("#")[-1], e.SecurityMode) for e in eps}
        check(all(m == ua.MessageSecurityMode.SignAndEncrypt for _, m in modes), f"endpoints {modes}")
        check({p for p, _ in modes} == {"Basic256Sha256", "Aes128_Sha256_RsaOaep", "Aes256_Sha256_RsaPss"},
              f"policies {modes}")
        for e in eps:
            kinds = {t.TokenType for t in e.UserIdentityTokens}
            check(kinds == {ua.UserTokenType.UserName}, f"tokens {kinds}")
        # Anonymous over None: refused.
        await refused(Client(serve.url), "an anonymous session over SecurityPolicy None")
        for policy in [security_policies.SecurityPolicyBasic256Sha256,
                       security_policies.SecurityPolicyAes256Sha256RsaPss,
                       security_policies.SecurityPolicyAes128Sha256RsaOaep]:
            c = await secure_client(serve.url, cert, key, uri, policy, "mes", "s3cret-mes")
            async with c:
                await c.load_data_type_definitions()
                ns, machine, rm = await machine_nodes(c, "line-2")
                handle, r, err = await call(rm, ns, "GetLatestResult", i32(0))
                p = [p for p in store_parts(DB) if p["station"] == "line-2"][-1]
                check(err == 0, f"GetLatestResult over {policy.__name__}: {err}")
                check_result(r, p, f"GetLatestResult over {policy.__name__}")
        # Wrong password, unknown user, no user, untrusted certificate: refused.
        await refused(await secure_client(serve.url, cert, key, uri,
                      security_policies.SecurityPolicyBasic256Sha256, "mes", "wrong"), "a wrong password")
        await refused(await secure_client(serve.url, cert, key, uri,
                      security_policies.SecurityPolicyBasic256Sha256, "nobody", "s3cret-mes"), "an unknown user")
        await refused(await secure_client(serve.url, cert, key, uri,
                      security_policies.SecurityPolicyBasic256Sha256), "an anonymous encrypted session")
        await refused(await secure_client(serve.url, *stranger,
                      security_policies.SecurityPolicyBasic256Sha256, "mes", "s3cret-mes"), "an untrusted client certificate")
        check(any((pki / "rejected").rglob("*")), "the untrusted certificate lands in rejected/")
        # A user cannot write either.
        c = await secure_client(serve.url, cert, key, uri, security_policies.SecurityPolicyBasic256Sha256, "qa", "other")
        async with c:
            ns, machine, rm = await machine_nodes(c, "line-2")
            phase = await (await machine.get_child(f"{ns[MACHINERY_NS]}:Monitoring")).get_child(f"{ns[GONIO_NS]}:Phase")
            try:
                await phase.write_value("push")
                fail("a user's write was accepted")
            except ua.UaStatusCodeError:
                pass
        # The same certificate next time (generated once).
        before = (pki / "own/cert.der").read_bytes()
    finally:
        serve.stop()
    serve = Serve(["--db", DB, "--station-name", "line-2", "--opcua", "127.0.0.1:0",
                   "--opcua-users", str(users), "--opcua-pki", str(pki), "--opcua-anonymous"])
    try:
        check((pki / "own/cert.der").read_bytes() == before, "the certificate is kept")
        # With --opcua-anonymous on loopback: None for anonymous only.
        c = Client(serve.url)
        eps = await c.connect_and_get_server_endpoints()
        none = [e for e in eps if e.SecurityMode == ua.MessageSecurityMode.None_]
        check(len(none) == 1 and {t.TokenType for t in none[0].UserIdentityTokens} == {ua.UserTokenType.Anonymous},
              f"None endpoint {none}")
        async with Client(serve.url) as c:
            await c.nodes.objects.get_children()
        c = Client(serve.url)
        c.set_user("mes")
        c.set_password("s3cret-mes")
        await refused(c, "a password over SecurityPolicy None")
    finally:
        serve.stop()
    print("security: encrypted sessions with a user work; anonymous, None, wrong passwords and unknown certificates are refused")


async def offloop():
    """Run inside a network namespace of its own where 192.0.2.1 (TEST-NET-1) is a local
    address that is not loopback."""
    pki = WORK / "pki"
    users = users_file({"mes": "s3cret-mes"})
    cert, key, uri = await make_cert("mes-client")
    (pki / "trusted").mkdir(parents=True, exist_ok=True)
    shutil.copy(cert, pki / "trusted" / cert.name)
    out = subprocess.run([GONIO, "serve", "--db", DB, "--station-name", "line-2", "--opcua",
                          "192.0.2.1:0", "--opcua-anonymous", "--opcua-users", str(users),
                          "--opcua-pki", str(pki)], capture_output=True, text=True, timeout=30)
    check(out.returncode == 2 and "loopback address only" in out.stderr,
          f"--opcua-anonymous off loopback: {out.returncode} {out.stderr}")
    serve = Serve(["--db", DB, "--station-name", "line-2", "--opcua", "192.0.2.1:0",
                   "--opcua-users", str(users), "--opcua-pki", str(pki)])
    try:
        check(serve.url.startswith("opc.tcp://192.0.2.1:"), serve.url)
        eps = await Client(serve.url).connect_and_get_server_endpoints()
        check(eps and all(e.SecurityMode == ua.MessageSecurityMode.SignAndEncrypt for e in eps),
              f"off loopback only Sign & Encrypt: {[(e.SecurityPolicyUri, e.SecurityMode) for e in eps]}")
        await refused(Client(serve.url), "an anonymous session off loopback")
        c = Client(serve.url)
        c.set_user("mes")
        c.set_password("s3cret-mes")
        await refused(c, "a password over SecurityPolicy None off loopback")
        c = await secure_client(serve.url, cert, key, uri, security_policies.SecurityPolicyBasic256Sha256,
                                "mes", "s3cret-mes")
        async with c:
            ns, machine, rm = await machine_nodes(c, "line-2")
            _, _, err = await call(rm, ns, "GetLatestResult", i32(0))
            check(err == 0, f"GetLatestResult off loopback: {err}")
    finally:
        serve.stop()
    print("offloop: off loopback only Sign & Encrypt with a user; anonymous and None refused")


def content(p):
    q = dict(p)
    for k in ["part", "batch", "started_at", "ended_at"]:
        q.pop(k)
    return q


async def robust():
    n_parts = 6
    serve = Serve(["--db", DB, "--station", "sim", "--parts", str(n_parts), "--seed", "5",
                   "--speed", "8", "--opcua", "127.0.0.1:0", "--opcua-anonymous"])
    host, port = serve.url[len("opc.tcp://"):].rstrip("/").rsplit(":", 1)
    try:
        watcher = Client(serve.url)
        await watcher.connect()
        h, _ = await subscribe(watcher, "sim")
        # A client that subscribes and is killed (no CloseSession, the socket just drops).
        killed = subprocess.Popen([sys.executable, "-c", f"""
import asyncio, time
from asyncua import Client
async def main():
    c = Client({serve.url!r})
    await c.connect()
    sub = await c.create_subscription(50, None)
    ns = await c.get_namespace_array()
    mon = await c.nodes.objects.get_child([f"{{ns.index({MACHINERY_NS!r})}}:Machines", f"{{ns.index({GONIO_NS!r})}}:sim", f"{{ns.index({MACHINERY_NS!r})}}:Monitoring"])
    await sub.subscribe_data_change(await mon.get_children())
    print("subscribed", flush=True)
    await asyncio.sleep(60)
asyncio.run(main())
"""], stdout=subprocess.PIPE, text=True)
        line = await asyncio.get_event_loop().run_in_executor(None, killed.stdout.readline)
        check(line.strip() == "subscribed", "the doomed client subscribed")
        # Garbage on the port: random bytes, a truncated hello, a hello declaring a huge
        # message, an HTTP request. The server closes each connection by itself (at the
        # latest after its 5 s hello timeout).
        rng = random.Random(7)
        payloads = [bytes(rng.getrandbits(8) for _ in range(4096)), b"HEL",
                    b"HELF\xff\xff\xff\x7f" + b"\x00" * 64, b"GET / HTTP/1.1\r\nHost: x\r\n\r\n",
                    b"MSGF" + bytes(rng.getrandbits(8) for _ in range(100))]

        async def garbage(payload):
            reader, writer = await asyncio.open_connection(host, int(port))
            writer.write(payload)
            await writer.drain()
            try:
                await asyncio.wait_for(reader.read(), 15)
            except asyncio.TimeoutError:
                fail(f"a connection sending {payload[:8]!r} is still open after 15 s")
            writer.close()

        garbage_done = asyncio.gather(*(garbage(p) for p in payloads))
        # 50 clients at once, each subscribed to Monitoring and the events.
        clients = [Client(serve.url) for _ in range(50)]
        await asyncio.gather(*(c.connect() for c in clients))
        subs = await asyncio.gather(*(subscribe(c, "sim", 200) for c in clients))
        killed.send_signal(signal.SIGKILL)
        killed.wait()
        await garbage_done
        await serve.wait_for(f"batch done: {n_parts} parts", 180)
        await wait_events(h, n_parts, serve, 30)
        for handler, _ in subs:
            check(handler.changes, "each of the 50 clients got data changes")
        phase = await watcher.get_node(ua.NodeId("Machine/Monitoring/PartsDone", (await namespaces(watcher))[GONIO_NS])).read_value()
        check(phase == n_parts, f"PartsDone {phase}")
        await asyncio.gather(*(c.disconnect() for c in clients))
        await watcher.disconnect()
        check(serve.alive(), "gonio serve still runs")
    finally:
        serve.stop()
    # The store holds the batch exactly as it is when run without the clients.
    solo = str(WORK / "solo.sqlite")
    out = subprocess.run([GONIO, "mount", "--sim", "--parts", str(n_parts), "--seed", "5", "--db", solo],
                         capture_output=True, text=True)
    check(out.returncode == 0, out.stderr)
    got, want = store_parts(DB), store_parts(solo)
    check([content(p) for p in got] == [content(p) for p in want],
          "the store's records equal a batch run without clients")
    print(f"robust: {n_parts} parts with 50 clients, garbage bytes and a killed client; store intact")


def thread_cpu(pid):
    """CPU seconds (user + system) of a process's threads, summed by thread name."""
    tick = os.sysconf("SC_CLK_TCK")
    out = {}
    for t in Path(f"/proc/{pid}/task").iterdir():
        stat = (t / "stat").read_text()
        name = stat[stat.index("(") + 1 : stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2 :].split()
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / tick
    return out


async def load():
    """The station's batch time with 50 subscribed clients against none (BENCHMARKS.md).

    The simulated station (by default at full fidelity, every frame rendered and run through
    the detector: busy on the CPU, as a real one is with its camera; GONIO_OPCUA_FIDELITY)
    mounts GONIO_OPCUA_PARTS parts as fast as it can (GONIO_OPCUA_SPEED, default 1000000:
    unpaced); in a run with clients, 50
    asyncua clients subscribe to Monitoring (100 ms) and the events while the first part is
    mounted. The time from the second part's start to the last part's end (the store's
    wall-clock times) is compared between runs of the same seed, alternated, so each run
    mounts the same parts."""
    from datetime import datetime

    # GONIO_OPCUA_NICE=1: the clients take only what the station leaves (on a line the MES
    # runs elsewhere); on a machine loaded by others that can starve them past their session.
    if os.environ.get("GONIO_OPCUA_NICE") == "1":
        os.nice(19)
    fidelity = os.environ.get("GONIO_OPCUA_FIDELITY", "frames")
    speed = os.environ.get("GONIO_OPCUA_SPEED", "1000000")
    n_parts = int(os.environ.get("GONIO_OPCUA_PARTS", "5"))
    rounds = int(os.environ.get("GONIO_OPCUA_ROUNDS", "2"))
    ts = lambda s: datetime.fromisoformat(s.replace("Z", "+00:00")).timestamp()
    spans = {0: [], 50: []}
    for r in range(rounds):
        for n in ([0, 50] if r % 2 == 0 else [50, 0]):
            db = str(WORK / f"load-{r}-{n}.sqlite")
            serve = Serve(["--db", db, "--station", "sim", "--parts", str(n_parts), "--seed", "3",
                           "--fidelity", fidelity, "--speed", speed,
                           "--opcua", "127.0.0.1:0", "--opcua-anonymous"])
            try:
                clients = [Client(serve.url) for _ in range(n)]
                await asyncio.gather(*(c.connect() for c in clients))
                subs = await asyncio.gather(*(subscribe(c, "sim", 100) for c in clients))
                t_subscribed = time.time()
                await serve.wait_for(f"batch done: {n_parts} parts", 3600)
                cpu = thread_cpu(serve.p.pid)
                for h, _ in subs:
                    await wait_events(h, n_parts - 1, serve, 120)
                await asyncio.gather(*(c.disconnect() for c in clients))
            finally:
                serve.stop()
            parts = store_parts(db)
            check(len(parts) == n_parts, f"{len(parts)} parts")
            check(not n or ts(parts[1]["started_at"]) >= t_subscribed,
                  "the clients subscribed before the second part started")
            span = ts(parts[-1]["ended_at"]) - ts(parts[1]["started_at"])
            spans[n].append(span)
            opcua = sum(v for k, v in cpu.items() if k == "gonio-opcua")
            total = sum(cpu.values())
            print(f"round {r}: {n:2} clients: parts 2-{n_parts}: {span:.3f} s; CPU of the "
                  f"process {total:.2f} s, of the OPC UA server's threads {opcua:.2f} s", flush=True)
    import statistics
    m0, m50 = statistics.median(spans[0]), statistics.median(spans[50])
    print(f"median without clients {m0:.3f} s, with 50 clients {m50:.3f} s: "
          f"{100 * (m50 / m0 - 1):+.2f} %; load average {os.getloadavg()}")


MODES = {"batch": batch, "security": security, "offloop": offloop, "robust": robust, "load": load}
asyncio.run(MODES[MODE]())
print("all checks passed")
