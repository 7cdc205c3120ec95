// What one datagram costs this machine's kernel on loopback, and a large copy: the figures of
// scenarios/platforms/x86_loopback.yaml (the DDS transport model's per-datagram and copy costs),
// measured, never fitted to Cyclone DDS's delivered rates. bench/dds_vs_cyclone.sh runs these and
// prints them beside the profile's values.
//   BM_LoopbackSendto/B    one sendto() of a B-byte UDP datagram to a socket on 127.0.0.1
//   BM_LoopbackRecvfrom/B  one recvfrom() of such a datagram waiting in the socket
//   BM_Memcpy/B            one memcpy of B bytes (bytes_per_second is the copy bandwidth)
#include <arpa/inet.h>
#include <benchmark/benchmark.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstring>
#include <stdexcept>
#include <vector>

namespace {

// A receiving socket with a 4 MiB buffer (if the host allows it) and a sending one, on loopback.
struct LoopbackPair {
  LoopbackPair() {
    rx = socket(AF_INET, SOCK_DGRAM, 0);
    tx = socket(AF_INET, SOCK_DGRAM, 0);
    if (rx < 0 || tx < 0) throw std::runtime_error("socket() failed");
    const int size = 4 << 20;
    setsockopt(rx, SOL_SOCKET, SO_RCVBUF, &size, sizeof size);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (bind(rx, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      throw std::runtime_error("bind() failed");
    }
    socklen_t len = sizeof to;
    getsockname(rx, reinterpret_cast<sockaddr*>(&to), &len);
  }
  ~LoopbackPair() {
    close(rx);
    close(tx);
  }
  LoopbackPair(const LoopbackPair&) = delete;
  LoopbackPair& operator=(const LoopbackPair&) = delete;

  void Send(const std::vector<char>& d) const {
    sendto(tx, d.data(), d.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
  }
  bool Receive(std::vector<char>* d) const {
    return recvfrom(rx, d->data(), d->size(), MSG_DONTWAIT, nullptr, nullptr) > 0;
  }
  void Drain(std::vector<char>* d) const {
    while (Receive(d)) {
    }
  }

  int rx{-1};
  int tx{-1};
  sockaddr_in to{};
};

// Batches of this many datagrams fit the 4 MiB buffer (with the kernel's overhead) at 64 KB.
constexpr int kBatch = 32;

void BM_LoopbackSendto(benchmark::State& state) {
  const LoopbackPair pair;
  std::vector<char> datagram(static_cast<std::size_t>(state.range(0)), 'x');
  std::vector<char> sink(65536);
  int in_batch = 0;
  for (auto _ : state) {
    pair.Send(datagram);
    if (++in_batch == kBatch) {
      state.PauseTiming();
      pair.Drain(&sink);
      in_batch = 0;
      state.ResumeTiming();
    }
  }
  pair.Drain(&sink);
  state.SetBytesProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_LoopbackSendto)->Arg(14720)->Arg(65000);

void BM_LoopbackRecvfrom(benchmark::State& state) {
  const LoopbackPair pair;
  std::vector<char> datagram(static_cast<std::size_t>(state.range(0)), 'x');
  std::vector<char> sink(65536);
  int left = 0;
  for (auto _ : state) {
    if (left == 0) {
      state.PauseTiming();
      for (int i = 0; i < kBatch; ++i) pair.Send(datagram);
      left = kBatch;
      state.ResumeTiming();
    }
    benchmark::DoNotOptimize(pair.Receive(&sink));
    --left;
  }
  pair.Drain(&sink);
  state.SetBytesProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_LoopbackRecvfrom)->Arg(14720)->Arg(65000);

void BM_Memcpy(benchmark::State& state) {
  const auto bytes = static_cast<std::size_t>(state.range(0));
  std::vector<char> from(bytes, 'x');
  std::vector<char> to(bytes);
  for (auto _ : state) {
    std::memcpy(to.data(), from.data(), bytes);
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_Memcpy)->Arg(4915200);

}  // namespace
