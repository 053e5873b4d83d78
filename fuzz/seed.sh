#!/usr/bin/env bash
# Seeds fuzz/corpus/<target>/ from the repository's own files: the spec files, the scenario
# library, the sample captures, the golden outputs of the command line, and the examples in
# the docs. Corpora are not committed (fuzz/.gitignore); run this before `cargo fuzz run`.
# Existing corpus files are kept, so seeding again only adds.
set -euo pipefail
cd "$(dirname "$0")"
repo=..
corpus=corpus

# One seed per argument: seed TARGET NAME (content on stdin).
seed() {
  mkdir -p "$corpus/$1"
  cat > "$corpus/$1/seed-$2"
}

# A file name for a short text: its SHA-1 (two texts never share one, unlike a transliteration).
hashname() {
  printf '%s' "$1" | sha1sum | cut -c1-16
}

# spec_loader: the first byte chooses the file (load order of specs/src/lib.rs), the rest is it.
i=0
for f in variables watchdog status checksums stop_commands scheduling profiles check; do
  { printf "\\x$(printf %02x $i)"; cat "$repo/specs/$f.yaml"; } | seed spec_loader "$f"
  i=$((i + 1))
done

# yaml_trace: the scenario library, the YAML capture, and the docs' YAML examples.
for f in "$repo"/specs/scenarios/*.yaml "$repo"/specs/captures/*.yaml; do
  seed yaml_trace "$(basename "$f")" < "$f"
done

# jsonl_trace: the JSON Lines captures.
for f in "$repo"/specs/captures/*.jsonl; do
  seed jsonl_trace "$(basename "$f")" < "$f"
done

# host_log: the sample host log.
for f in "$repo"/specs/captures/*.log; do
  seed host_log "$(basename "$f")" < "$f"
done

# Fenced blocks of the docs, each sorted by what it is: a JSON Lines trace, a YAML trace
# (`version:` first), a host log (`>` or `#` lines), or command lines (`pmacwd ...`).
blocks=$(mktemp -d)
trap 'rm -rf "$blocks"' EXIT
for doc in "$repo"/README.md "$repo"/docs/*.md; do
  awk -v out="$blocks/$(basename "$doc" .md)" '
    /^```/ { if (inside) { inside = 0 } else { inside = 1; n++ }; next }
    inside { print > (out "-" n) }' "$doc"
done
for b in "$blocks"/*; do
  [ -s "$b" ] || continue
  first=$(head -n1 "$b")
  name=doc-$(basename "$b")
  case "$first" in
    '{"format"'*) seed jsonl_trace "$name" < "$b" ;;
    version:*) seed yaml_trace "$name" < "$b" ;;
    '>'* | '#'*) grep -q '^> ' "$b" && seed host_log "$name" < "$b" ;;
  esac
  n=0
  # Every `pmacwd ...` line of a block, as the NUL-separated arguments command_line reads.
  { grep -E '^(\$ )?pmacwd( |$)' "$b" || true; } | while IFS= read -r l; do
    n=$((n + 1))
    printf '%s' "$l" | sed -E 's/^(\$ )?pmacwd ?//; s/ +#.*//' | tr -s ' ' '\0' | seed command_line "$name-$n"
  done
done

# command_line: every command of the golden outputs; `<tmp>` stands for a temporary folder.
n=0
for f in "$repo"/cli/tests/golden/*.txt; do
  n=$((n + 1))
  head -n1 "$f" | sed -E 's/^command: pmacwd ?//; s/<tmp>/tmp/g' | tr -d '\n"' | tr ' ' '\0' \
    | seed command_line "golden-$(basename "$f" .txt)"
done

# status_reply: the replies `pmacwd decode` is tested with, and every reply the traces expect.
for r in 001000000000 800400000000 400000080000 'BOOTSTRAP PROM' ERR003 zzz; do
  printf '%s' "$r" | seed status_reply "decode-$(hashname "$r")"
done
printf '\aERR003\r' | seed status_reply error-reply
printf 'BOOTSTRAP PROM\r\006' | seed status_reply bootstrap-ack
printf '001000000000\r\006' | seed status_reply words-ack
{ grep -ho 'reply: *"[^"]*"' "$repo"/specs/scenarios/*.yaml "$repo"/specs/captures/*.yaml || true; } \
  | sed -E 's/reply: *"(.*)"/\1/' | sort -u | while IFS= read -r r; do
  printf '%s' "$r" | seed status_reply "trace-$(hashname "$r")"
done

# host_command: the commands of the traces, of check.yaml, and of the host log.
{
  grep -ho 'command: *"[^"]*"' "$repo"/specs/scenarios/*.yaml "$repo"/specs/captures/*.yaml \
    | sed -E 's/command: *"(.*)"/\1/'
  grep -ho '"command":"[^"]*"' "$repo"/specs/captures/*.jsonl | sed -E 's/"command":"(.*)"/\1/'
  grep -h '^> ' "$repo"/specs/captures/*.log | sed 's/^> //'
  grep -A20 '^ *commands:' "$repo"/specs/check.yaml | grep -o '"[^"]*"' | tr -d '"'
  printf '%s\n' '???' 'I40' 'I130 = 7' 'I5100=$10' 'rhy:$000025' 'RHX:$1080' '$$$' 'open plc 1' \
    'OPEN PROG 10' 'close' 'I40=-5' 'HELLO'
} | sort -u | while IFS= read -r c; do
  printf '%s' "$c" | seed host_command "$(hashname "$c")"
done

# card_grammar: the same host commands, and the run-together lines real clients send:
# dls-pmaccontrol 3.2.3's poll line (emulator/benches/serve.rs) and the EPICS pmac driver's
# fast poll list (cli/tests/gui/test_epics_poll.py), plus ranges, downloads and addressing.
mkdir -p "$corpus/card_grammar"
cp "$corpus"/host_command/seed-* "$corpus/card_grammar/"
gui=$(printf 'i65???&1??%%'; for m in 1 2 3 4 5 6 7 8; do printf '#%d?PVF m%d90 p99' $m $m; done)
printf '%s' "$gui" | seed card_grammar gui-poll-line
epics=$(printf ' ??? M70 M71 M72 M73 M4039 M4040 M4038'; for a in 1 2 3 4 5 6 7 8; do printf ' #%dP #%dF i%d24 #%d?' $a $a $a $a; done)
printf '%s' "$epics" | seed card_grammar epics-fast-poll
printf '%s\n' 'i20..23' '#1J+#2J-&1B1R' '&1Q&2H&3A' 'open prog 1 clear x10 close' 'MS0,I910' \
  'ENABLE PLC 1' 'DISABLE PLC 1' 'SAVE' '$$$' 'I5=2 I3=2 I6=1' 'DEFINE GATHER' '#3K' '%50' \
  'M100->D:$002082 M100=9 I130' 'M1..8->X:$25,0,24,S M1..8 M1..3->' 'WX:$2082,7,-1 WY:$10000,$FFFFFF' \
  'M5->Y:$10000,4,4,D M5=98 M6->F:$0607FF M6=1.5 M6' 'M0..8191->*' \
  | while IFS= read -r c; do
  printf '%s' "$c" | seed card_grammar "$(hashname "$c")"
done
printf '\001\004\013\021' | seed card_grammar control-characters

# ethernet_header: the headers dls-pmaclib sends (emulator/src/protocol.rs), and a refused one.
printf '\x40\xbf\x00\x00\x00\x00\x00\x0d' | seed ethernet_header getresponse
printf '\xc0\xc5\x00\x00\x00\x00\x08\x00' | seed ethernet_header getbuffer
printf '\xc0\xc2\x00\x00\x00\x00\x00\x02' | seed ethernet_header readready
printf '\x40\xb3\x00\x00\x00\x00\x00\x00' | seed ethernet_header flush
printf '\xc0\xc4\x00\x01\x00\x00\x00\x00' | seed ethernet_header ctrl-a
printf '\x40\xbf\x00\x00\x00\x00\x05\xd5' | seed ethernet_header too-long

# emulator_stream: whole request streams as dls-pmaclib and the EPICS driver send them (the
# first byte is the piece size the target writes in: 0 all at once, 1 a byte at a time).
req() { # req CODE TYPE LINE: a request header for LINE, then LINE
  printf "\\x$2\\x$1\\x00\\x00\\x00\\x00\\x$(printf %02x $((${#3} >> 8)))\\x$(printf %02x $((${#3} & 255)))%s" "$3"
}
{ printf '\000'; req bf 40 'i6=1 i3=2 ver'; req bf 40 '???'; } | seed emulator_stream handshake
{ printf '\001'; req bf 40 '???'; req bf 40 'I130=5 I130'; } | seed emulator_stream byte-by-byte
{ printf '\007'; req bf 40 "$(printf '??? %.0s' $(seq 373))"; printf '\xc0\xc5\x00\x00\x00\x00\x00\x00'; printf '\xc0\xc5\x00\x00\x00\x00\x00\x00'; } \
  | seed emulator_stream long-reply-getbuffer
{ printf '\000'; req b0 40 'I40'; printf '\xc0\xc2\x00\x00\x00\x00\x00\x02'; printf '\xc0\xb1\x00\x00\x00\x00\x00\x00'; } \
  | seed emulator_stream sendline-readready-getline
{ printf '\000'; req bf 40 'M0..8191->X:$0,0,24,S'; req bf 40 'M0..8191-> M0..8191->'; printf '\x40\xb3\x00\x00\x00\x00\x00\x00'; req bf 40 'P0..8191'; } \
  | seed emulator_stream ranges-flush
{ printf '\003'; printf '\xc0\xc4\x00\x0b\x00\x00\x00\x00'; req bf 40 'OPEN PLC 1 P1=1'; req bf 40 'CLOSE ???'; } \
  | seed emulator_stream control-and-buffer

# framing: command lines and replies as framed under I3 and I6 (emulator/src/framing.rs).
printf 'i6=1 i3=2 ver' | seed framing line
printf ' ???  OPEN PLC 1 I130\r' | seed framing line-open
printf '25\r50\r75\r\006' | seed framing reply-i3-2
printf '\n25\r\n50\r\n75\r\n' | seed framing reply-i3-1
printf '\aERR003\r' | seed framing error-i6-1
printf '\a\rERR003\r' | seed framing error-i6-3
printf '\002\001\0021.947\377\000\377\002000FFF\377\001\000\003' | seed framing answers

for t in "$corpus"/*/; do
  echo "$(basename "$t"): $(find "$t" -type f | wc -l) files"
done
