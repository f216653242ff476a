#pragma once
// HTTPS for the server: the certificate and private key it presents, loaded and checked before
// it listens, so that a wrong file stops the service at its start rather than failing every
// handshake later. TLS 1.2 is the oldest version offered; the ciphers are OpenSSL's defaults.
// A renewed certificate is loaded again while the server runs (skinspecd: SIGHUP).

#include <expected>
#include <memory>
#include <mutex>
#include <string>

namespace boost::asio::ssl {
class context;
}

namespace skinspec::api {

struct TlsFiles {
  std::string certificate;  // PEM: the server's certificate, then any intermediate ones
  std::string private_key;  // PEM, unencrypted
};

// The server side of TLS with `files`; an explanation naming the file at fault when one cannot
// be read, holds no certificate or key, or the key is not the certificate's.
std::expected<std::shared_ptr<boost::asio::ssl::context>, std::string> make_tls_context(const TlsFiles& files);

// The context each new connection takes. Replacing it (a renewed certificate) changes what the
// next handshakes present; a connection keeps the context it started with until it closes.
class TlsCredentials {
 public:
  explicit TlsCredentials(std::shared_ptr<boost::asio::ssl::context> context) : context_(std::move(context)) {}
  std::shared_ptr<boost::asio::ssl::context> current() const {
    std::lock_guard lock(mutex_);
    return context_;
  }
  void replace(std::shared_ptr<boost::asio::ssl::context> context) {
    std::lock_guard lock(mutex_);
    context_ = std::move(context);
  }

 private:
  mutable std::mutex mutex_;
  std::shared_ptr<boost::asio::ssl::context> context_;
};

}  // namespace skinspec::api
