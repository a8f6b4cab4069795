#!/usr/bin/env bash
# liblockroll.so exports the C ABI and nothing else: every defined dynamic symbol starts with
# lockroll_ (no C++ of lockroll's or of the standard library's templates, which would clash with
# a host program's), and every function <lockroll/lockroll.h> declares is exported.
#   exported_symbols_test.sh LIBLOCKROLL_SO LOCKROLL_H
set -euo pipefail
lib=$1 header=$2
syms=$(nm -D --defined-only "$lib" | awk '{print $NF}')
[ -n "$syms" ] || { echo "nm found no dynamic symbols in $lib" >&2; exit 1; }
others=$(grep -v '^lockroll_' <<<"$syms" || true)
if [ -n "$others" ]; then
  echo "$lib exports symbols that are not lockroll_*:" >&2
  head -20 <<<"$others" >&2
  exit 1
fi
declared=$(grep -o 'LOCKROLL_API [^(]*(' "$header" | grep -o 'lockroll_[a-z_]*($' | tr -d '(' | sort -u)
[ -n "$declared" ] || { echo "no LOCKROLL_API functions found in $header" >&2; exit 1; }
missing=$(comm -23 <(echo "$declared") <(sort -u <<<"$syms"))
[ -z "$missing" ] || { echo "declared in $header but not exported: $missing" >&2; exit 1; }
# The builder's settings the C ABI promises (issue 23), exported whatever the header says.
for f in lockroll_builder_spectator lockroll_builder_spectators lockroll_builder_join lockroll_builder_record_replay \
         lockroll_builder_desync_report_dir lockroll_builder_disconnect_timeouts lockroll_output_error \
         lockroll_builder_server_spectator lockroll_builder_connect_token; do
  grep -qx "$f" <<<"$syms" || { echo "$lib does not export $f" >&2; exit 1; }
done
echo "liblockroll.so: $(wc -l <<<"$syms") symbols, all lockroll_*, all $(wc -l <<<"$declared") declared ones exported"
