#include "skinspec/api/tls.hpp"

#include <openssl/err.h>
#include <openssl/ssl.h>

#include <fstream>

#include <boost/asio/ssl/context.hpp>

namespace skinspec::api {

namespace ssl = boost::asio::ssl;

namespace {

// The file's own error first: OpenSSL's for a missing file is "system lib", which says little.
std::expected<void, std::string> readable(const std::string& flag, const std::string& path) {
  if (path.empty()) return std::unexpected(flag + " names no file");
  if (!std::ifstream(path)) return std::unexpected(flag + " " + path + ": cannot read the file");
  return {};
}

std::string failure(const std::string& flag, const std::string& path, const std::string& what,
                    const boost::system::error_code& ec) {
  return flag + " " + path + ": " + what + " (" + ec.message() + ")";
}

}  // namespace

std::expected<std::shared_ptr<ssl::context>, std::string> make_tls_context(const TlsFiles& files) {
  if (auto ok = readable("--tls-cert", files.certificate); !ok) return std::unexpected(ok.error());
  if (auto ok = readable("--tls-key", files.private_key); !ok) return std::unexpected(ok.error());
  auto context = std::make_shared<ssl::context>(ssl::context::tls_server);
  // SSLv3, TLS 1.0 and 1.1 have known weaknesses and no client of ours needs them.
  if (SSL_CTX_set_min_proto_version(context->native_handle(), TLS1_2_VERSION) != 1)
    return std::unexpected("OpenSSL refused TLS 1.2 as the oldest version");
  context->set_options(ssl::context::default_workarounds | ssl::context::single_dh_use);
  // The key first: OpenSSL then takes any certificate, and a key that is not its own shows as
  // the certificate having no key, below, rather than as a fault of either file.
  boost::system::error_code ec;
  if (context->use_private_key_file(files.private_key, ssl::context::pem, ec); ec)
    return std::unexpected(failure("--tls-key", files.private_key, "no usable PEM private key", ec));
  if (context->use_certificate_chain_file(files.certificate, ec); ec)
    return std::unexpected(failure("--tls-cert", files.certificate, "no PEM certificate", ec));
  if (SSL_CTX_check_private_key(context->native_handle()) != 1) {
    ERR_clear_error();
    return std::unexpected("--tls-key " + files.private_key + ": not the private key of the certificate in " +
                           files.certificate);
  }
  return context;
}

}  // namespace skinspec::api
