#!/usr/bin/env bash
# geld over TLS on loopback, with certificates the test makes itself (openssl): a plain-text
# client gets nothing; a TLS client that trusts the CA and carries the token is served; the
# same without the token is refused; with --tls-client-ca a client without a certificate cannot
# connect and one with a certificate signed by that CA is served. Bad TLS options are refused
# at start (exit 2), each naming the option, the file and what is wrong with it: a key that does
# not match its certificate, a certificate that does not parse, a key given as a certificate.
# The client is Debian's python3-grpcio with the project's stubs.
#
#   test_tls.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
geld=$build/server/geld
gelctl=$build/client/gelctl
py=/usr/bin/python3
work=$(mktemp -d /tmp/geld-tls.XXXXXX)
source "$(dirname "$0")/geld_lib.sh"
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
  code=$?
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
# Files that are PEM but not what the option needs were reported as "cannot listen on
# 127.0.0.1:PORT" (gRPC's failure to build its TLS context), naming neither option nor file.
openssl req -newkey rsa:2048 -nodes -keyout other.key -out other.csr -subj "/CN=other" 2> /dev/null
chmod 600 other.key
refused --tls-cert server.pem --tls-key other.key
grep -q "tls-key: other.key does not match the certificate in server.pem" refused.log || fail "a mismatched key: $(cat refused.log)"
[ "$code" -eq 2 ] || fail "a mismatched key: exit $code, expected 2 (configuration)"
printf -- '-----BEGIN CERTIFICATE-----\nbm90IGEgY2VydGlmaWNhdGU=\n-----END CERTIFICATE-----\n' > garbage.pem
refused --tls-cert garbage.pem --tls-key server.key
grep -q "tls-cert: garbage.pem is not a PEM certificate" refused.log || fail "a garbage certificate: $(cat refused.log)"
[ "$code" -eq 2 ] || fail "a garbage certificate: exit $code, expected 2 (configuration)"
refused --tls-cert server.key --tls-key server.key
grep -q "tls-cert: server.key is not a PEM certificate" refused.log || fail "a key as the certificate: $(cat refused.log)"
cp ca.pem cert-as-key.pem && chmod 600 cert-as-key.pem
refused --tls-cert server.pem --tls-key cert-as-key.pem
grep -q "tls-key: cert-as-key.pem is not a PEM private key" refused.log || fail "a certificate as the key: $(cat refused.log)"
refused --tls-cert server.pem --tls-key server.key --tls-client-ca garbage.pem
grep -q "tls-client-ca: garbage.pem is not a PEM certificate" refused.log || fail "a garbage client CA: $(cat refused.log)"
refused --tls-cert missing.pem --tls-key server.key
grep -q "tls-cert: cannot read missing.pem" refused.log || fail "a missing certificate: $(cat refused.log)"
echo "tls: plain text refused, token still required, mutual TLS enforced, bad options refused"
