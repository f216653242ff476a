#pragma once
// Who holds the server's connections, and whom a newcomer may displace, so that no client can
// lock others out by holding connections open and sending nothing.
//
// Each client address may hold `per_client` connections and everyone together `total`. A
// connection is idle while it waits for the first byte of its next request (a new connection
// included) and busy from that byte until its response is written. A newcomer over a limit
// takes the place of the connection that has been idle longest (that client's own at the
// per-client limit, anyone's at the total cap), which the server then closes; a newcomer is
// refused only when every connection it could displace is busy. Not thread-safe: the server
// guards it with its own mutex.

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>

namespace skinspec::api::detail {

class ConnectionTable {
 public:
  using Id = std::uint64_t;
  struct Limits {
    std::size_t total = 512;
    std::size_t per_client = 64;
  };
  enum class Refusal { none, client_full, server_full };
  struct Admission {
    Refusal refusal = Refusal::none;  // none: admitted
    std::optional<Id> evicted;        // to be closed now; no longer in the table
  };

  explicit ConnectionTable(Limits limits);

  // A new connection `id` from `client`; admitted as idle.
  Admission admit(Id id, const std::string& client);
  // The connection waits for its next request.
  void set_idle(Id id);
  // A request started arriving; false when the connection was evicted meanwhile and must close.
  bool set_busy(Id id);
  void remove(Id id);

  std::size_t size() const { return entries_.size(); }
  std::size_t count(const std::string& client) const;
  const Limits& limits() const { return limits_; }

 private:
  using IdleOrder = std::set<std::pair<std::uint64_t, Id>>;  // (when it became idle, id), oldest first
  struct Entry {
    std::string client;
    std::uint64_t idle_since = 0;  // 0: busy
  };
  struct Client {
    std::size_t count = 0;
    IdleOrder idle;
  };

  // Removes the longest-idle connection of `order`, if any, and returns it.
  std::optional<Id> evict_oldest(const IdleOrder& order);
  void forget_idle(Id id, Entry& entry);

  Limits limits_;
  std::uint64_t clock_ = 0;
  std::unordered_map<Id, Entry> entries_;
  std::map<std::string, Client> clients_;
  IdleOrder idle_;
};

}  // namespace skinspec::api::detail
