#!/usr/bin/env bash
# geld over TLS on loopback, with certificates the test makes itself (openssl): a plain-text
# client gets nothing; a TLS client that trusts the CA and carries the token is served; the
# same without the token is refused; with --tls-client-ca a client without a certificate cannot
# connect and one with a certificate signed by that CA is served. Bad TLS options are refused
# at start. The client is Debian's python3-grpcio with the project's stubs.
#
#   test_tls.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
geld=$build/server/geld
gelctl=$build/client/gelctl
py=/usr/bin/python3
work=$(mktemp -d /tmp/geld-tls.XXXXXX)
geld_pid=
stop_geld() {
  if [ -n "$geld_pid" ]; then
    kill -TERM "$geld_pid" 2>/dev/null || true
    wait "$geld_pid" 2>/dev/null || true
    geld_pid=
  fi
}
trap 'stop_geld; rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; [ -f "$work/geld.log" ] && tail -5 "$work/geld.log" >&2; exit 1; }
command -v openssl > /dev/null || fail "openssl is needed to make the test certificates"
port=$($py -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()')

# A CA, a server certificate for 127.0.0.1/localhost and a client certificate, all signed by it.
cd "$work"
openssl req -x509 -newkey rsa:2048 -nodes -keyout ca.key -out ca.pem -days 2 -subj "/CN=gel test CA" 2> /dev/null
openssl req -newkey rsa:2048 -nodes -keyout server.key -out server.csr -subj "/CN=localhost" 2> /dev/null
printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\n' > san.ext
openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out server.pem -days 2 -extfile san.ext 2> /dev/null
openssl req -newkey rsa:2048 -nodes -keyout client.key -out client.csr -subj "/CN=gel test client" 2> /dev/null
openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out client.pem -days 2 2> /dev/null
chmod 600 server.key client.key
echo "s3cret-token" > token && chmod 600 token

start_geld() {
  "$geld" --listen "127.0.0.1:$port" --data-dir "$work/data" --workers 1 --token-file token "$@" > "$work/geld.log" 2>&1 &
  geld_pid=$!
  for _ in $(seq 100); do grep -q "listening" "$work/geld.log" 2>/dev/null && return; kill -0 "$geld_pid" 2>/dev/null || break; sleep 0.05; done
  fail "geld did not start with $*"
}

# Prints OK or the gRPC status code name of one ListJobs call.
call() {
  $py - "$build/client/python" "127.0.0.1:$port" "$@" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
import grpc
from gel.v1 import service_pb2, service_pb2_grpc
address, mode, token = sys.argv[2], sys.argv[3], sys.argv[4]
if mode == "plain":
    channel = grpc.insecure_channel(address)
else:
    read = lambda path: open(path, "rb").read()
    cert = dict(private_key=read("client.key"), certificate_chain=read("client.pem")) if mode == "tls+cert" else {}
    channel = grpc.secure_channel(address, grpc.ssl_channel_credentials(root_certificates=read("ca.pem"), **cert))
metadata = [("authorization", "Bearer " + token)] if token != "-" else []
try:
    service_pb2_grpc.GelServiceStub(channel).ListJobs(service_pb2.ListJobsRequest(), metadata=metadata, timeout=5)
    print("OK")
except grpc.RpcError as error:
    print(error.code().name)
PY
}
expect() {
  local got
  got=$(call "$2" "$3")
  [ "$got" = "$1" ] || fail "$2 with token '$3': expected $1, got $got"
}

# 1. Server TLS.
start_geld --tls-cert server.pem --tls-key server.key
grep -q "(TLS)" geld.log || fail "the log does not say TLS"
expect OK tls s3cret-token
expect UNAUTHENTICATED tls -
expect UNAUTHENTICATED tls wrong
expect UNAVAILABLE plain s3cret-token
"$gelctl" --server "127.0.0.1:$port" --token-file token --tls-ca ca.pem list > /dev/null || fail "gelctl over TLS"
if "$gelctl" --server "127.0.0.1:$port" --token-file token --timeout 3 list > /dev/null 2>&1; then fail "gelctl in plain text was served"; fi
stop_geld

# 2. Mutual TLS: a client certificate is required before any call.
start_geld --tls-cert server.pem --tls-key server.key --tls-client-ca ca.pem
grep -q "(mutual TLS)" geld.log || fail "the log does not say mutual TLS"
expect OK tls+cert s3cret-token
expect UNAVAILABLE tls s3cret-token
"$gelctl" --server "127.0.0.1:$port" --token-file token --tls-ca ca.pem --tls-cert client.pem --tls-key client.key list > /dev/null \
  || fail "gelctl with a client certificate"
if "$gelctl" --server "127.0.0.1:$port" --token-file token --tls-ca ca.pem --timeout 3 list > /dev/null 2>&1; then
  fail "gelctl without a client certificate was served"
fi
stop_geld

# 3. Refusals at start, each naming the option.
refused() {
  set +e
  timeout 10 "$geld" --listen "127.0.0.1:$port" --data-dir "$work/data" --token-file token "$@" > "$work/refused.log" 2>&1
  local code=$?
  set -e
  [ "$code" -ne 0 ] && [ "$code" -ne 124 ] || fail "geld started with $*"
}
refused --tls-cert server.pem
grep -q "go together" refused.log || fail "a certificate without a key: $(cat refused.log)"
chmod 644 server.key
refused --tls-cert server.pem --tls-key server.key
grep -q "readable by others" refused.log || fail "a readable key: $(cat refused.log)"
chmod 600 server.key
refused --tls-cert san.ext --tls-key server.key
grep -q "not a PEM file" refused.log || fail "a non-PEM certificate: $(cat refused.log)"
echo "tls: plain text refused, token still required, mutual TLS enforced, bad options refused"
