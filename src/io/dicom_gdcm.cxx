/*
 * io/dicom_gdcm.cxx — the C-ABI adapter over GDCM (dicom_adapter.h); the
 * only C++ in the project (DESIGN §5: DICOM is too large a standard to
 * parse by hand). It reads, nothing more: series grouping, slice order,
 * spacing, checks and messages are dicom.c's.
 *
 * Every GDCM call is inside a try block: no exception crosses into C.
 * GDCM's trace streams are silenced once, so the library never prints.
 */
#include "dicom_adapter.h"

#include <gdcmDataSet.h>
#include <gdcmFile.h>
#include <gdcmImage.h>
#include <gdcmImageHelper.h>
#include <gdcmImageReader.h>
#include <gdcmPixelFormat.h>
#include <gdcmReader.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <istream>
#include <streambuf>
#include <string>
#include <vector>

namespace {

void quiet() {
    static bool done = false;
    if (done) return;
    done = true;
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
}

/* A read-only stream over the caller's bytes (no copy; std::istringstream
 * would also instantiate string-buffer code into libvolux.so's symbols). */
struct memory_buf : std::streambuf {
    memory_buf(const void *p, size_t n) {
        char *b = const_cast<char *>(static_cast<const char *>(p));
        setg(b, b, b + n);
    }
    pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
        char *target = dir == std::ios_base::beg ? eback() + off : dir == std::ios_base::cur ? gptr() + off : egptr() + off;
        if (target < eback() || target > egptr()) return pos_type(off_type(-1));
        setg(eback(), target, egptr());
        return pos_type(target - eback());
    }
    pos_type seekpos(pos_type pos, std::ios_base::openmode mode) override {
        return seekoff(off_type(pos), std::ios_base::beg, mode);
    }
};

void say(char *msg, size_t n, const char *text) {
    if (msg && n) std::snprintf(msg, n, "%s", text);
}

/* The value of a string element, without DICOM's space/NUL padding. */
std::string text(const gdcm::DataSet &ds, uint16_t group, uint16_t element) {
    const gdcm::Tag tag(group, element);
    if (!ds.FindDataElement(tag)) return std::string();
    const gdcm::ByteValue *bv = ds.GetDataElement(tag).GetByteValue();
    if (!bv || !bv->GetPointer()) return std::string();
    std::string s(bv->GetPointer(), bv->GetLength());
    size_t end = s.find_last_not_of(std::string(" \0", 2));
    s = end == std::string::npos ? std::string() : s.substr(0, end + 1);
    size_t begin = s.find_first_not_of(' ');
    return begin == std::string::npos ? std::string() : s.substr(begin);
}

void copy_text(char *dst, const std::string &s) {
    std::snprintf(dst, VOLUX_DICOM_TEXT, "%s", s.c_str());
    for (char *p = dst; *p; p++)
        if ((unsigned char)*p < 0x20) *p = ' ';
}

/* A backslash-separated list of decimal strings (DS/IS): exactly `count`
 * finite numbers, else false. */
bool numbers(const std::string &s, int count, double *out) {
    const char *p = s.c_str();
    for (int i = 0; i < count; i++) {
        char *end;
        double v = std::strtod(p, &end);
        if (end == p || !std::isfinite(v)) return false;
        out[i] = v;
        while (*end == ' ') end++;
        if (i + 1 < count) {
            if (*end != '\\') return false;
            p = end + 1;
        } else if (*end) {
            return false;
        }
    }
    return true;
}

bool read_file(gdcm::Reader &reader, const char *path, std::istream &ss, bool up_to_pixels) {
    if (!path) {
        reader.SetStream(ss);
    } else {
        reader.SetFileName(path);
    }
    if (!up_to_pixels) return reader.Read();
    return reader.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010), std::set<gdcm::Tag>());
}

int info(const char *path, const void *mem, size_t n, volux_dicom_info *out, char *msg, size_t msg_size) {
    quiet();
    std::memset(out, 0, sizeof *out);
    gdcm::Reader reader;
    memory_buf mb(mem ? mem : "", mem ? n : 0);
    std::istream ss(&mb);
    if (!read_file(reader, mem ? nullptr : path, ss, true)) {
        say(msg, msg_size, "not a DICOM file (GDCM cannot parse it)");
        return VOLUX_DICOM_NOT_DICOM;
    }
    const gdcm::File &file = reader.GetFile();
    const gdcm::DataSet &ds = file.GetDataSet();
    copy_text(out->series_uid, text(ds, 0x0020, 0x000e));
    copy_text(out->description, text(ds, 0x0008, 0x103e));
    copy_text(out->modality, text(ds, 0x0008, 0x0060));
    const char *ts = gdcm::TransferSyntax::GetTSString(file.GetHeader().GetDataSetTransferSyntax());
    copy_text(out->transfer_syntax, ts ? ts : "");
    double v[6];
    if (numbers(text(ds, 0x0020, 0x0011), 1, v) && std::fabs(v[0]) < 1e9) out->series_number = (int)v[0];
    if (numbers(text(ds, 0x0020, 0x0013), 1, v) && std::fabs(v[0]) < 1e9) {
        out->instance_number = (int)v[0];
        out->has_instance = 1;
    }
    if (numbers(text(ds, 0x0018, 0x1120), 1, v)) out->gantry_tilt = v[0];
    if (!ds.FindDataElement(gdcm::Tag(0x0028, 0x0010)) || !ds.FindDataElement(gdcm::Tag(0x0028, 0x0011))) {
        say(msg, msg_size, "no image (no Rows/Columns)");
        return VOLUX_DICOM_NO_IMAGE;
    }
    std::vector<unsigned int> dims = gdcm::ImageHelper::GetDimensionsValue(file);
    if (dims.size() < 2) {
        say(msg, msg_size, "no image dimensions");
        return VOLUX_DICOM_NO_IMAGE;
    }
    const unsigned int big = 1u << 30;
    out->columns = dims[0] < big ? (int)dims[0] : -1;
    out->rows = dims[1] < big ? (int)dims[1] : -1;
    out->frames = dims.size() > 2 && dims[2] > 0 ? (dims[2] < big ? (int)dims[2] : -1) : 1;
    gdcm::PixelFormat pf = gdcm::ImageHelper::GetPixelFormatValue(file);
    out->samples = pf.GetSamplesPerPixel();
    out->bits_allocated = pf.GetBitsAllocated();
    out->bits_stored = pf.GetBitsStored();
    out->pixel_signed = pf.GetPixelRepresentation() == 1;
    out->pixel_float = pf.GetScalarType() == gdcm::PixelFormat::FLOAT32 ||
                       pf.GetScalarType() == gdcm::PixelFormat::FLOAT64;
    /* Classic images: the attributes themselves, so that a missing one is
     * seen as missing (GDCM fills defaults). Enhanced multi-frame objects
     * keep them in functional groups: GDCM's helpers read those. */
    bool enhanced = ds.FindDataElement(gdcm::Tag(0x5200, 0x9229)) || ds.FindDataElement(gdcm::Tag(0x5200, 0x9230));
    if (numbers(text(ds, 0x0020, 0x0032), 3, out->position)) {
        out->has_position = 1;
    } else if (enhanced) {
        std::vector<double> o = gdcm::ImageHelper::GetOriginValue(file);
        if (o.size() == 3 && std::isfinite(o[0]) && std::isfinite(o[1]) && std::isfinite(o[2])) {
            for (int i = 0; i < 3; i++) out->position[i] = o[(size_t)i];
            out->has_position = 1;
        }
    }
    if (numbers(text(ds, 0x0020, 0x0037), 6, out->orientation)) {
        out->has_orientation = 1;
    } else if (enhanced) {
        std::vector<double> d;
        if (gdcm::ImageHelper::GetDirectionCosinesFromDataSet(ds, d) && d.size() == 6) {
            for (int i = 0; i < 6; i++) out->orientation[i] = d[(size_t)i];
            out->has_orientation = 1;
        } else {
            d = gdcm::ImageHelper::GetDirectionCosinesValue(file);
            if (d.size() == 6) {
                for (int i = 0; i < 6; i++) out->orientation[i] = d[(size_t)i];
                out->has_orientation = 1;
            }
        }
    }
    /* Pixel Spacing is row spacing (y), then column spacing (x). GDCM's
     * GetSpacingValue asserts (aborts) on some single-frame objects that
     * lack NumberOfFrames (Debian's build keeps asserts): it is only asked
     * for multi-frame files, which have that attribute. */
    double ps[2];
    if (numbers(text(ds, 0x0028, 0x0030), 2, ps) || numbers(text(ds, 0x0018, 0x1164), 2, ps)) {
        out->spacing[0] = ps[1];
        out->spacing[1] = ps[0];
    }
    if (out->frames > 1 && ds.FindDataElement(gdcm::Tag(0x0028, 0x0008))) {
        std::vector<double> sp = gdcm::ImageHelper::GetSpacingValue(file);
        for (size_t i = 0; i < 3; i++)
            if (i < sp.size() && std::isfinite(sp[i]) && sp[i] > 0 && (i == 2 || out->spacing[i] <= 0))
                out->spacing[i] = sp[i];
    }
    std::vector<double> is = gdcm::ImageHelper::GetRescaleInterceptSlopeValue(file);
    out->intercept = is.size() == 2 ? is[0] : 0.0;
    out->slope = is.size() == 2 ? is[1] : 1.0;
    return VOLUX_DICOM_OK;
}

/* Whether the native Pixel Data element of length `vl` runs past the end
 * of the file. GDCM does not say where the element starts, so this finds
 * its header — the tag (7FE0,0010) in either byte order followed by an
 * explicit VR (OB/OW, 2 reserved bytes) or by the 4-byte length itself —
 * whose length field is `vl`, searching from the end (the element is last
 * but for optional padding). No header found: nothing to say. */
bool native_cut(const char *path, const void *mem, size_t n, unsigned long long vl, unsigned long long *have) {
    /* Only the file's tail can hold the element: its last vl + 64 KiB. */
    std::vector<unsigned char> own;
    const unsigned char *b = static_cast<const unsigned char *>(mem);
    unsigned long long base = 0, total = n;
    if (!mem) {
        std::FILE *f = std::fopen(path, "rb");
        if (!f) return false;
        if (std::fseek(f, 0, SEEK_END) != 0) {
            std::fclose(f);
            return false;
        }
        long end = std::ftell(f);
        total = end > 0 ? (unsigned long long)end : 0;
        unsigned long long window = vl + 65536 < total ? vl + 65536 : total;
        base = total - window;
        own.resize((size_t)window);
        bool ok = std::fseek(f, (long)base, SEEK_SET) == 0 && std::fread(own.data(), 1, own.size(), f) == own.size();
        std::fclose(f);
        if (!ok) return false;
        b = own.data();
        n = own.size();
    }
    auto u32 = [](const unsigned char *p, bool big) {
        return big ? (unsigned long long)p[0] << 24 | (unsigned long long)p[1] << 16 | (unsigned long long)p[2] << 8 | p[3]
                   : (unsigned long long)p[3] << 24 | (unsigned long long)p[2] << 16 | (unsigned long long)p[1] << 8 | p[0];
    };
    for (size_t i = n >= 8 ? n - 8 : 0; n >= 8; i--) {
        bool le = b[i] == 0xE0 && b[i + 1] == 0x7F && b[i + 2] == 0x10 && b[i + 3] == 0x00;
        bool be = b[i] == 0x7F && b[i + 1] == 0xE0 && b[i + 2] == 0x00 && b[i + 3] == 0x10;
        if (le || be) {
            size_t start = 0;
            if (i + 12 <= n && b[i + 4] == 'O' && (b[i + 5] == 'B' || b[i + 5] == 'W') && u32(b + i + 8, be) == vl)
                start = i + 12;
            else if (u32(b + i + 4, be) == vl)
                start = i + 8;
            if (start) {
                *have = total - (base + start);
                return base + start + vl > total;
            }
        }
        if (i == 0) break;
    }
    return false;
}

int pixels(const char *path, const void *mem, size_t n, void *buf, size_t bytes, char *msg, size_t msg_size) {
    quiet();
    gdcm::ImageReader reader;
    memory_buf mb(mem ? mem : "", mem ? n : 0);
    std::istream ss(&mb);
    if (mem) {
        reader.SetStream(ss);
    } else {
        reader.SetFileName(path);
    }
    if (!reader.Read()) {
        say(msg, msg_size, "GDCM cannot read the image (truncated or corrupt file, or no pixel data)");
        return VOLUX_DICOM_BAD;
    }
    const gdcm::Image &image = reader.GetImage();
    /* Native pixel data cut short: GDCM keeps the declared length and
     * reads what is there without a word (the rest stays zero). */
    const gdcm::ByteValue *native = image.GetDataElement().GetByteValue();
    if (native) {
        unsigned long long vl = native->GetLength(), have = 0;
        if (vl < bytes || native_cut(path, mem, n, vl, &have)) {
            char text_msg[200];
            std::snprintf(text_msg, sizeof text_msg,
                          "pixel data is truncated: %llu of its %llu bytes are in the file (the image needs %zu)",
                          vl < bytes ? vl : have, vl, bytes);
            say(msg, msg_size, text_msg);
            return VOLUX_DICOM_BAD;
        }
    }
    unsigned long len = image.GetBufferLength();
    if (len != bytes) {
        char text_msg[160];
        std::snprintf(text_msg, sizeof text_msg, "pixel data decodes to %lu bytes, the header needs %zu", len, bytes);
        say(msg, msg_size, text_msg);
        return VOLUX_DICOM_BAD;
    }
    if (!image.GetBuffer(static_cast<char *>(buf))) {
        char text_msg[200];
        std::snprintf(text_msg, sizeof text_msg, "GDCM cannot decode the pixel data (transfer syntax %s)",
                      gdcm::TransferSyntax::GetTSString(image.GetTransferSyntax()));
        say(msg, msg_size, text_msg);
        return VOLUX_DICOM_BAD;
    }
    return VOLUX_DICOM_OK;
}

} // namespace

extern "C" int volux_dicom_adapter_info(const char *path, const void *mem, size_t n, volux_dicom_info *out, char *msg,
                                        size_t msg_size) {
    try {
        return info(path, mem, n, out, msg, msg_size);
    } catch (const std::exception &e) {
        say(msg, msg_size, e.what());
    } catch (...) {
        say(msg, msg_size, "GDCM failed reading the header");
    }
    return VOLUX_DICOM_BAD;
}

extern "C" int volux_dicom_adapter_pixels(const char *path, const void *mem, size_t n, void *buf, size_t bytes,
                                          char *msg, size_t msg_size) {
    try {
        return pixels(path, mem, n, buf, bytes, msg, msg_size);
    } catch (const std::exception &e) {
        say(msg, msg_size, e.what());
    } catch (...) {
        say(msg, msg_size, "GDCM failed decoding the pixels");
    }
    return VOLUX_DICOM_BAD;
}
