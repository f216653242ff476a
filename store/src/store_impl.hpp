#pragma once
// What a Store holds: its engine (the connections and what differs between engines), its
// options and what opening found, and the wrappers that turn a body of work into one
// transaction and a Failure into a returned StoreError.

#include <memory>
#include <string>
#include <type_traits>

#include "audit_record.hpp"
#include "engine.hpp"
#include "local_notifications.hpp"
#include "skinspec/store/store.hpp"

namespace skinspec::store {

namespace detail {

// Runs `body`, returning its value, or the StoreError it threw with `what` in front.
template <typename F>
auto guarded(std::string_view what, F&& body) -> Result<std::invoke_result_t<F>> {
  using T = std::invoke_result_t<F>;
  auto with_context = [&](StoreError error) {
    error.message = std::string(what) + ": " + error.message;
    return std::unexpected(std::move(error));
  };
  try {
    if constexpr (std::is_void_v<T>) {
      body();
      return {};
    } else {
      return body();
    }
  } catch (const Failure& failure) {
    return with_context(failure.error);
  } catch (const std::bad_alloc&) {
    return with_context(StoreError{StoreError::Kind::internal, "out of memory", 0});
  }
}

}  // namespace detail

struct Store::Impl {
  std::string path;
  Backend backend = Backend::sqlite;
  OpenOptions options;
  int version = 0;
  RecoveryReport recovery;
  std::unique_ptr<detail::Engine> engine;
  std::shared_ptr<detail::LocalHub> hub = std::make_shared<detail::LocalHub>();  // SQLite's notifications

  Time now() const;
  // The clock leases are judged by (docs/store.md, "Benches"): the PostgreSQL server's, one
  // clock for every bench whatever their own machines' say; this machine's for SQLite, whose one
  // writer works on this machine; OpenOptions::clock when a test sets it.
  Time database_now(detail::Connection& c) const;

  // One write transaction around `body(connection)`, committed when it returns, with its audit
  // row when this thread has an actor (AuditScope): `what` is the change it records. A failure
  // that left nothing committed and may pass (a lost connection, a serialisation conflict) is
  // tried once more.
  template <typename F>
  auto write(std::string_view what, F&& body) -> Result<std::invoke_result_t<F, detail::Connection&>> {
    return detail::guarded(what, [&] {
      for (int attempt = 1;; ++attempt) {
        auto connection = engine->writer();
        try {
          detail::Transaction transaction(*connection, detail::TransactionKind::write);
          if constexpr (std::is_void_v<std::invoke_result_t<F, detail::Connection&>>) {
            body(*connection);
            if (detail::recording_changes()) detail::record_change(*connection, what, now());
            transaction.commit();
            return;
          } else {
            auto value = body(*connection);
            if (detail::recording_changes()) detail::record_change(*connection, what, now());
            transaction.commit();
            return value;
          }
        } catch (const detail::Failure& failure) {
          if (!failure.retryable || attempt == 2) throw;
        }
      }
    });
  }

  // One read transaction (a consistent snapshot) on a pooled read connection. A read that
  // found its connection gone (a database server restarted) is run once more on a new one.
  template <typename F>
  auto read(std::string_view what, F&& body) const -> Result<std::invoke_result_t<F, detail::Connection&>> {
    return detail::guarded(what, [&] {
      return retried_once([&] {
        auto connection = engine->reader();
        detail::Transaction transaction(*connection, detail::TransactionKind::read);
        auto value = checked_read(body, *connection);
        transaction.commit();
        engine->after_read();
        return value;
      });
    });
  }

  // A read whose body runs exactly one statement, which is its own snapshot: no transaction
  // around it (one round trip fewer where the database is a server). A body that runs a second
  // statement fails as `internal`, so a change that adds one cannot go unnoticed.
  template <typename F>
  auto read_one(std::string_view what, F&& body) const -> Result<std::invoke_result_t<F, detail::Connection&>> {
    return detail::guarded(what, [&] {
      return retried_once([&] {
        auto connection = engine->reader();
        const auto before = connection->statements_prepared();
        auto value = checked_read(body, *connection);
        if (connection->statements_prepared() - before > 1)
          detail::fail(StoreError::Kind::internal, "a single-statement read ran more than one statement");
        engine->after_read();
        return value;
      });
    });
  }

 private:
  template <typename F>
  static auto retried_once(F&& attempt) {
    try {
      return attempt();
    } catch (const detail::Failure& failure) {
      if (!failure.retryable) throw;
      return attempt();
    }
  }

  template <typename F>
  auto checked_read(F& body, detail::Connection& connection) const {
    try {
      return body(connection);
    } catch (const detail::Failure&) {
      engine->after_read();  // a change under the reader explains whatever it ran into
      throw;
    }
  }
};

}  // namespace skinspec::store
