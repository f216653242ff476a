#include "connection_table.hpp"

#include <algorithm>

namespace skinspec::api::detail {

ConnectionTable::ConnectionTable(Limits limits) : limits_(limits) {
  limits_.total = std::max<std::size_t>(1, limits_.total);
  limits_.per_client = std::clamp<std::size_t>(limits_.per_client, 1, limits_.total);
}

ConnectionTable::Admission ConnectionTable::admit(Id id, const std::string& client) {
  Admission admission;
  if (const auto it = clients_.find(client); it != clients_.end() && it->second.count >= limits_.per_client) {
    admission.evicted = evict_oldest(it->second.idle);
    if (!admission.evicted) return {Refusal::client_full, std::nullopt};
  }
  if (entries_.size() >= limits_.total) {
    admission.evicted = evict_oldest(idle_);
    if (!admission.evicted) return {Refusal::server_full, std::nullopt};
  }
  auto& entry = entries_[id];
  entry.client = client;
  auto& owner = clients_[client];
  ++owner.count;
  entry.idle_since = ++clock_;
  owner.idle.emplace(entry.idle_since, id);
  idle_.emplace(entry.idle_since, id);
  return admission;
}

void ConnectionTable::set_idle(Id id) {
  const auto it = entries_.find(id);
  if (it == entries_.end()) return;
  forget_idle(id, it->second);
  it->second.idle_since = ++clock_;
  clients_[it->second.client].idle.emplace(it->second.idle_since, id);
  idle_.emplace(it->second.idle_since, id);
}

bool ConnectionTable::set_busy(Id id) {
  const auto it = entries_.find(id);
  if (it == entries_.end()) return false;
  forget_idle(id, it->second);
  return true;
}

void ConnectionTable::remove(Id id) {
  const auto it = entries_.find(id);
  if (it == entries_.end()) return;
  forget_idle(id, it->second);
  const auto owner = clients_.find(it->second.client);
  if (owner != clients_.end() && --owner->second.count == 0) clients_.erase(owner);
  entries_.erase(it);
}

std::size_t ConnectionTable::count(const std::string& client) const {
  const auto it = clients_.find(client);
  return it == clients_.end() ? 0 : it->second.count;
}

std::optional<ConnectionTable::Id> ConnectionTable::evict_oldest(const IdleOrder& order) {
  if (order.empty()) return std::nullopt;
  const Id victim = order.begin()->second;
  remove(victim);
  return victim;
}

void ConnectionTable::forget_idle(Id id, Entry& entry) {
  if (entry.idle_since == 0) return;
  idle_.erase({entry.idle_since, id});
  if (const auto owner = clients_.find(entry.client); owner != clients_.end())
    owner->second.idle.erase({entry.idle_since, id});
  entry.idle_since = 0;
}

}  // namespace skinspec::api::detail
