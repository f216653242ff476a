#pragma once
// LISTEN on a connection of its own, made again when it is lost.

#include <memory>
#include <string>
#include <vector>

#include "postgresql/target.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::store::postgresql {

// Connects and listens now; throws unreachable or access_denied as connecting does.
std::unique_ptr<Subscription> subscribe(const Target& target, const std::vector<std::string>& channels);

}  // namespace skinspec::store::postgresql
