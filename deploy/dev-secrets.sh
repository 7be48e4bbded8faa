#!/bin/sh
# For docker compose on one host: a self-signed TLS pair for localhost
# (secrets/tls.crt, tls.key), one tenant "dev" with a random token
# (secrets/client.token; secrets/tokens holds only its hash) and a Redis
# password (.env, read by compose). Not for production: use your CA there.
set -eu
cd "$(dirname "$0")" && mkdir -p secrets && umask 077
openssl req -x509 -newkey rsa:2048 -nodes -days 365 -subj /CN=localhost -addext "subjectAltName=DNS:localhost,DNS:server,IP:127.0.0.1" -keyout secrets/tls.key -out secrets/tls.crt 2>/dev/null
openssl rand -hex 32 > secrets/client.token
echo "dev $(tr -d '\n' < secrets/client.token | sha256sum | cut -d' ' -f1)" > secrets/tokens
echo "VPREMESH_REDIS_PASSWORD=$(openssl rand -hex 24)" > .env
# The server container runs as another (non-root) user: it must read these.
chmod 644 secrets/tls.crt secrets/tls.key secrets/tokens
echo "deploy/secrets/ and deploy/.env written; client: --token-file deploy/secrets/client.token --tls-ca deploy/secrets/tls.crt"
