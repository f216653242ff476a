#include "postgresql/subscription.hpp"

#include <poll.h>

#include <chrono>

#include <fmt/format.h>

#include "postgresql/connection.hpp"
#include "store_impl.hpp"

namespace skinspec::store::postgresql {

namespace {

class PgSubscription final : public Subscription {
 public:
  PgSubscription(Target target, std::vector<std::string> channels)
      : target_(std::move(target)), channels_(std::move(channels)) {
    connect();
  }

  Result<std::vector<Notification>> wait(std::chrono::milliseconds timeout) override {
    return detail::guarded("listening for notifications", [&] {
      if (!connection_) connect();
      const auto deadline = std::chrono::steady_clock::now() + timeout;
      for (;;) {
        auto arrived = drain();
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
        if (!arrived.empty() || left <= std::chrono::milliseconds::zero()) return arrived;
        // Readable may mean part of a message, or none: read what there is and look again.
        pollfd readable{PQsocket(connection_->handle()), POLLIN, 0};
        if (poll(&readable, 1, static_cast<int>(left.count())) > 0 && PQconsumeInput(connection_->handle()) == 0) {
          connection_.reset();  // made again at the next wait
          detail::fail(StoreError::Kind::unreachable, fmt::format("the connection to {} was lost", target_.display));
        }
      }
    });
  }

 private:
  void connect() {
    connection_.reset();
    ConnectSettings settings;
    settings.application_name = "skinspec listener";
    auto connection = std::make_unique<Connection>(target_, settings);
    for (const auto& channel : channels_) {
      std::unique_ptr<char, decltype(&PQfreemem)> quoted(
          PQescapeIdentifier(connection->handle(), channel.data(), channel.size()), &PQfreemem);
      if (!quoted) detail::fail(StoreError::Kind::invalid_argument, fmt::format("no channel can be named {}", channel));
      connection->execute(std::string("LISTEN ") + quoted.get());
    }
    connection_ = std::move(connection);
  }

  std::vector<Notification> drain() {
    std::vector<Notification> out;
    while (PGnotify* notice = PQnotifies(connection_->handle())) {
      out.push_back({notice->relname, notice->extra});
      PQfreemem(notice);
    }
    return out;
  }

  Target target_;
  std::vector<std::string> channels_;
  std::unique_ptr<Connection> connection_;
};

}  // namespace

std::unique_ptr<Subscription> subscribe(const Target& target, const std::vector<std::string>& channels) {
  return std::make_unique<PgSubscription>(target, channels);
}

}  // namespace skinspec::store::postgresql
