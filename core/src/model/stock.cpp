// Stock files (MODEL.md section 6): parsing, validation, serialisation.
//
// One table per struct lists every key with its member, range and unit;
// parsing, validation and serialisation all walk that table, so a key
// cannot be read under one name and written under another.
#include "filmgrain/stock.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "model/presets_embedded.h"

namespace filmgrain {

namespace {

using Json = nlohmann::ordered_json;

/// A numeric key of a struct with its allowed range.
template<typename T> struct NumberField {
    const char* key;
    double T::*member;
    double lo;
    double hi;
    bool lo_open;  ///< lo itself is not allowed
};

const NumberField<Population> kPopulationFields[] = {
    { "grains_per_um2", &Population::grains_per_um2, 0.0, 100.0, true },
    { "diameter_um", &Population::diameter_um, 0.01, 1000.0, false },
    { "diameter_log_sigma", &Population::diameter_log_sigma, 0.0, 1.5, false },
    { "quantum_efficiency", &Population::quantum_efficiency, 0.0, 1.0, false },
    { "k_pair_per_s", &Population::k_pair_per_s, 0.0, 1e15, false },
    { "k_join_per_s", &Population::k_join_per_s, 0.0, 1e15, false },
    { "k_loss_per_s", &Population::k_loss_per_s, 0.0, 1e15, false },
    { "rate_area_exponent", &Population::rate_area_exponent, -4.0, 4.0, false },
    { "max_dye_density", &Population::max_dye_density, 0.0, 20.0, false },
};

const NumberField<Layer> kLayerFields[] = {
    { "base_density", &Layer::base_density, 0.0, 10.0, false },
    { "scatter", &Layer::scatter, 0.0, 1.0, false },
    { "scatter_sigma_um", &Layer::scatter_sigma_um, 0.0, 1000.0, false },
    { "halation", &Layer::halation, 0.0, 1.0, false },
    { "halation_radius_um", &Layer::halation_radius_um, 0.0, 5000.0, false },
    { "cloud_diameter_ratio", &Layer::cloud_diameter_ratio, 0.1, 10.0, false },
    { "cloud_density", &Layer::cloud_density, 0.0, 20.0, true },
};

/// A key that names one of a few words: the key, the enumeration's names
/// (filmgrain/names.h) and where it is stored in a T (a Layer or the Stock).
template<typename T, typename E, size_t N> struct WordField {
    const char* key;
    const Named<E> (&names)[N];
    E T::*member;
};

const NumberField<Stock> kStockFields[] = {
    { "exposure_at_grey_lxs", &Stock::exposure_at_grey_lxs, 0.0, 1e6, true },
    { "development_time_s", &Stock::development_time_s, 0.0, 1e7, false },
    { "development_tau_s", &Stock::development_tau_s, 0.0, 1e12, true },
    { "fog_tau_s", &Stock::fog_tau_s, 0.0, 1e30, true },
    { "base_density", &Stock::base_density, 0.0, 10.0, false },
    { "max_density", &Stock::max_density, 0.0, 20.0, true },
    { "inhibitor_diffusion_um", &Stock::inhibitor_diffusion_um, 0.0, 1000.0, false },
    { "base_thickness_um", &Stock::base_thickness_um, 0.0, 2000.0, false },
    { "base_refractive_index", &Stock::base_refractive_index, 1.3, 2.0, false },
};

/// Largest entry of the inhibition matrix (MODEL.md 10): exp(-10 D) at a
/// density of 1 already stops development.
constexpr double kMaxInhibition = 10.0;

constexpr size_t kMaxLayers      = 16;
constexpr size_t kMaxPopulations = 16;

/// The fewest significant digits that read back as v (0.4, not
/// 0.40000000000000002; 1.0000000000000002 stays distinct from 1), whole
/// numbers below 1e17 written out (1000000, not 1e+06).
std::string format_number(double v)
{
    char buf[40];
    int digits = 1;
    for (; digits < 17; ++digits) {
        std::snprintf(buf, sizeof buf, "%.*g", digits, v);
        if (std::strtod(buf, nullptr) == v)
            break;
    }
    if (std::isfinite(v) && v != 0.0) {
        const int exponent = static_cast<int>(std::floor(std::log10(std::fabs(v))));
        if (exponent >= 0 && exponent < 17)
            digits = std::max(digits, exponent + 1);
    }
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return buf;
}

template<typename T>
Status check_range(const NumberField<T>& f, double v, const std::string& path)
{
    const bool ok = std::isfinite(v) && (f.lo_open ? v > f.lo : v >= f.lo) && v <= f.hi;
    if (ok)
        return {};
    return Status::errorf(path, f.key, " = ", format_number(v), ": must be in ",
                          f.lo_open ? "(" : "[", format_number(f.lo), ", ",
                          format_number(f.hi), "]");
}

std::string type_name(const Json& j)
{
    return j.type_name();
}

Status expect_object(const Json& j, const std::string& path)
{
    if (!j.is_object())
        return Status::errorf(path.empty() ? "the stock" : path,
                              " must be a JSON object, not ", type_name(j));
    return {};
}

/// Reads the numeric keys of `fields` from `j` into `out`, rejecting keys
/// that are neither numeric fields nor listed in `other_keys`.
template<typename T, size_t N>
Status read_numbers(const Json& j, const NumberField<T> (&fields)[N],
                    const std::set<std::string>& other_keys,
                    const std::string& path, T& out)
{
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& key = it.key();
        const NumberField<T>* field = nullptr;
        for (const auto& f : fields)
            if (key == f.key)
                field = &f;
        if (!field) {
            if (other_keys.count(key))
                continue;
            std::string allowed;
            for (const auto& f : fields)
                allowed += std::string(allowed.empty() ? "" : ", ") + f.key;
            for (const auto& k : other_keys)
                allowed += ", " + k;
            return Status::errorf("unknown key '", path, key, "'; allowed keys here: ",
                                  allowed);
        }
        if (!it->is_number())
            return Status::errorf(path, key, " must be a number, not ",
                                  type_name(*it), " (", it->dump(), ")");
        out.*(field->member) = it->template get<double>();
    }
    return {};
}

Status read_string(const Json& j, const char* key, const std::string& path, std::string& out)
{
    auto it = j.find(key);
    if (it == j.end())
        return {};
    if (!it->is_string())
        return Status::errorf(path, key, " must be a string, not ", type_name(*it));
    out = it->get<std::string>();
    return {};
}

Status parse_population(const Json& j, const std::string& path, Population& out)
{
    if (Status s = expect_object(j, path); !s)
        return s;
    return read_numbers(j, kPopulationFields, {}, path + ".", out);
}

const WordField<Layer, HalationKernel, 3> kHalationKernelField { "halation_kernel",
                                                                kHalationKernelNames,
                                                                &Layer::halation_kernel };
const WordField<Layer, LayerImage, 2> kImageField { "image", kLayerImageNames, &Layer::image };
const WordField<Layer, CloudProfile, 2> kCloudProfileField { "cloud_profile", kCloudProfileNames,
                                                             &Layer::cloud_profile };
const WordField<Stock, RearFace, 2> kRearFaceField { "rear_face", kRearFaceNames,
                                                     &Stock::rear_face };

template<typename T, typename E, size_t N>
Status read_word(const Json& j, const WordField<T, E, N>& field, const std::string& prefix,
                 T& out)
{
    std::string word;
    if (Status s = read_string(j, field.key, prefix, word); !s)
        return s;
    if (value_in(field.names, word, out.*(field.member)))
        return {};
    return Status::errorf(prefix, field.key, " = '", word, "': must be one of ",
                          names_in(field.names, ", ", "'"));
}

Status parse_layer(const Json& j, const std::string& path, Layer& out)
{
    if (Status s = expect_object(j, path); !s)
        return s;
    const std::string prefix = path + ".";
    const std::set<std::string> other_keys = { "name", "sensitivity", "populations",
                                               "halation_kernel", "image", "cloud_profile" };
    if (Status s = read_numbers(j, kLayerFields, other_keys, prefix, out); !s)
        return s;
    for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string& key = it.key();
        if (key == "name") {
            if (Status s = read_string(j, "name", prefix, out.name); !s)
                return s;
        } else if (key == "halation_kernel") {
            if (Status s = read_word(j, kHalationKernelField, prefix, out); !s)
                return s;
        } else if (key == "image") {
            if (Status s = read_word(j, kImageField, prefix, out); !s)
                return s;
        } else if (key == "cloud_profile") {
            if (Status s = read_word(j, kCloudProfileField, prefix, out); !s)
                return s;
        } else if (key == "sensitivity") {
            if (!it->is_array() || it->size() != 3)
                return Status::errorf(prefix, "sensitivity must be an array of 3 numbers "
                                      "(weights on scene-linear R, G, B), not ", it->dump());
            for (size_t c = 0; c < 3; ++c) {
                if (!(*it)[c].is_number())
                    return Status::errorf(prefix, "sensitivity[", c, "] must be a number, not ",
                                          type_name((*it)[c]));
                out.sensitivity[c] = (*it)[c].get<double>();
            }
        } else if (key == "populations") {
            if (!it->is_array())
                return Status::errorf(prefix, "populations must be an array of objects, not ",
                                      type_name(*it));
            out.populations.clear();
            for (size_t p = 0; p < it->size(); ++p) {
                Population pop;
                if (Status s = parse_population((*it)[p], prefix + "populations["
                                                + std::to_string(p) + "]", pop);
                    !s)
                    return s;
                out.populations.push_back(pop);
            }
        }
    }
    return {};
}

// --- MODEL.md 11: printing_density (Status M -> APD) ----------------------

/// Largest magnitude of an entry of the Status M -> APD map: S-2008-002
/// Annex C's maps are near the identity (diagonal 0.96-1.10, the rest
/// within 0.03, offsets within 0.05).
constexpr double kMaxApdMapEntry = 10.0;

/// Reads `n` numbers of the array `j` (at `path`) into `out`.
Status read_number_array(const Json& j, const std::string& path, size_t n, double* out)
{
    if (!j.is_array() || j.size() != n)
        return Status::errorf(path, " must be an array of ", n, " numbers, not ", j.dump());
    for (size_t i = 0; i < n; ++i) {
        if (!j[i].is_number())
            return Status::errorf(path, "[", i, "] must be a number, not ", type_name(j[i]),
                                  " (", j[i].dump(), ")");
        out[i] = j[i].get<double>();
    }
    return {};
}

/// `printing_density: { status_m_to_apd: { matrix: [[3x3]], offset: [3] } }`,
/// the datasheets' form (stocks/datasheets/README.md); every key required.
Status parse_printing_density(const Json& j, Stock& out)
{
    const std::string top = "printing_density";
    if (Status s = expect_object(j, top); !s)
        return s;
    for (auto it = j.begin(); it != j.end(); ++it)
        if (it.key() != "status_m_to_apd")
            return Status::errorf("unknown key '", top, ".", it.key(),
                                  "'; allowed keys here: status_m_to_apd");
    const auto map = j.find("status_m_to_apd");
    if (map == j.end())
        return Status::errorf(top, " needs status_m_to_apd (the Status M -> APD map)");
    const std::string path = top + ".status_m_to_apd";
    if (Status s = expect_object(*map, path); !s)
        return s;
    for (auto it = map->begin(); it != map->end(); ++it)
        if (it.key() != "matrix" && it.key() != "offset")
            return Status::errorf("unknown key '", path, ".", it.key(),
                                  "'; allowed keys here: matrix, offset");
    StatusMToApd m;
    for (const char* key : { "matrix", "offset" })
        if (!map->contains(key))
            return Status::errorf(path, " needs ", key,
                                  " (APD = matrix * Status M + offset, S-2008-002 Annex C)");
    const Json& matrix = (*map)["matrix"];
    if (!matrix.is_array() || matrix.size() != 3)
        return Status::errorf(path, ".matrix must be 3 rows of 3 numbers, not ", matrix.dump());
    for (size_t r = 0; r < 3; ++r)
        if (Status s = read_number_array(matrix[r], path + ".matrix[" + std::to_string(r) + "]",
                                         3, m.matrix[r].data());
            !s)
            return s;
    if (Status s = read_number_array((*map)["offset"], path + ".offset", 3, m.offset.data()); !s)
        return s;
    out.status_m_to_apd = m;
    return {};
}

Status validate_printing_density(const Stock& stock)
{
    if (!stock.status_m_to_apd)
        return {};
    const std::string path = "printing_density.status_m_to_apd.";
    const StatusMToApd& m  = *stock.status_m_to_apd;
    const auto check = [&](double v, const std::string& where) {
        if (std::isfinite(v) && std::fabs(v) <= kMaxApdMapEntry)
            return Status();
        return Status::errorf(path, where, " = ", format_number(v), ": must be in [",
                              format_number(-kMaxApdMapEntry), ", ",
                              format_number(kMaxApdMapEntry), "]");
    };
    for (size_t r = 0; r < 3; ++r) {
        for (size_t c = 0; c < 3; ++c)
            if (Status s = check(m.matrix[r][c], "matrix[" + std::to_string(r) + "]["
                                                     + std::to_string(c) + "]");
                !s)
                return s;
        if (Status s = check(m.offset[r], "offset[" + std::to_string(r) + "]"); !s)
            return s;
    }
    for (const char* name : { "R", "G", "B" }) {
        const bool found = std::any_of(stock.layers.begin(), stock.layers.end(),
                                       [&](const Layer& l) { return l.name == name; });
        if (!found)
            return Status::errorf("printing_density maps the densities of the layers named R, "
                                  "G and B; the stock has no layer ", name);
    }
    return {};
}

}  // namespace

Status Stock::validate() const
{
    for (const auto& f : kStockFields)
        if (Status s = check_range(f, this->*(f.member), ""); !s)
            return s;
    if (layers.empty() || layers.size() > kMaxLayers)
        return Status::errorf("layers has ", layers.size(), " entries: must have 1 to ",
                              kMaxLayers);
    std::set<std::string> names;
    for (size_t i = 0; i < layers.size(); ++i) {
        const Layer& layer       = layers[i];
        const std::string prefix = "layers[" + std::to_string(i) + "].";
        if (layer.name.empty())
            return Status::errorf(prefix, "name is empty: must name the output channel");
        for (char c : layer.name)
            if (static_cast<unsigned char>(c) < 0x20 || c == ':' || c == ',')
                return Status::errorf(prefix, "name '", layer.name,
                                      "' contains a control character, ':' or ','");
        if (!names.insert(layer.name).second)
            return Status::errorf(prefix, "name '", layer.name,
                                  "' repeats an earlier layer's name: channel names must be unique");
        double sum = 0.0;
        for (size_t c = 0; c < 3; ++c) {
            const double w = layer.sensitivity[c];
            if (!std::isfinite(w) || w < 0.0 || w > 100.0)
                return Status::errorf(prefix, "sensitivity[", c, "] = ", format_number(w),
                                      ": must be in [0, 100]");
            sum += w;
        }
        if (sum <= 0.0)
            return Status::errorf(prefix, "sensitivity is all zero: the layer could never "
                                  "be exposed");
        for (const auto& f : kLayerFields)
            if (Status s = check_range(f, layer.*(f.member), prefix); !s)
                return s;
        if (layer.scatter > 0.0 && layer.scatter_sigma_um <= 0.0)
            return Status::errorf(prefix, "scatter = ", format_number(layer.scatter),
                                  " needs scatter_sigma_um > 0 (the width of the spread)");
        if (layer.halation_kernel == HalationKernel::base) {
            // The base kernel's size is the base's (docs/model.md, "Halation
            // from the base"): a radius as well would say two things.
            if (layer.halation_radius_um != 0.0)
                return Status::errorf(prefix, "halation_radius_um = ",
                                      format_number(layer.halation_radius_um),
                                      " with halation_kernel 'base': the base kernel's size "
                                      "follows from base_thickness_um and "
                                      "base_refractive_index; give 0 or leave it out");
            if (layer.halation > 0.0 && base_thickness_um <= 0.0)
                return Status::errorf(prefix, "halation = ", format_number(layer.halation),
                                      " with halation_kernel 'base' needs the stock's "
                                      "base_thickness_um > 0 (it is ",
                                      format_number(base_thickness_um), ")");
        } else if (layer.halation > 0.0 && layer.halation_radius_um <= 0.0) {
            return Status::errorf(prefix, "halation = ", format_number(layer.halation),
                                  " needs halation_radius_um > 0 (the radius of the halo)");
        }
        if (layer.populations.empty() || layer.populations.size() > kMaxPopulations)
            return Status::errorf(prefix, "populations has ", layer.populations.size(),
                                  " entries: must have 1 to ", kMaxPopulations);
        for (size_t p = 0; p < layer.populations.size(); ++p) {
            const std::string pprefix = prefix + "populations[" + std::to_string(p) + "].";
            const Population& pop = layer.populations[p];
            for (const auto& f : kPopulationFields)
                if (Status s = check_range(f, pop.*(f.member), pprefix); !s)
                    return s;
            if (pop.coupler_limited()
                && (layer.image != LayerImage::dye || layer.cloud_profile != CloudProfile::disc))
                return Status::errorf(pprefix, "max_dye_density = ",
                                      format_number(pop.max_dye_density),
                                      " needs a dye layer with disc clouds (image 'dye', "
                                      "cloud_profile 'disc'); 0 means no coupler limit");
            if (pop.max_dye_density > layer.cloud_density)
                return Status::errorf(pprefix, "max_dye_density = ",
                                      format_number(pop.max_dye_density), " is above the "
                                      "layer's cloud_density (", format_number(layer.cloud_density),
                                      "): a coupler limit must be at most one cloud's density");
        }
    }
    if (!inhibition.empty()) {
        if (inhibition.size() != layers.size())
            return Status::errorf("inhibition has ", inhibition.size(), " rows: must have one per "
                                  "layer (", layers.size(), ")");
        for (size_t k = 0; k < inhibition.size(); ++k) {
            if (inhibition[k].size() != layers.size())
                return Status::errorf("inhibition[", k, "] has ", inhibition[k].size(),
                                      " entries: must have one per layer (", layers.size(), ")");
            for (size_t j = 0; j < inhibition[k].size(); ++j) {
                const double v = inhibition[k][j];
                if (!std::isfinite(v) || v < 0.0 || v > kMaxInhibition)
                    return Status::errorf("inhibition[", k, "][", j, "] = ", format_number(v),
                                          ": must be in [0, ", format_number(kMaxInhibition), "]");
            }
        }
    }
    return validate_printing_density(*this);
}

bool Stock::inhibits() const
{
    for (const auto& row : inhibition)
        for (double v : row)
            if (v != 0.0)
                return true;
    return false;
}

Status parse_stock_json(const std::string& text, const std::string& origin, Stock& out)
{
    const std::string where = origin.empty() ? std::string("stock") : origin;
    Json j;
    try {
        j = Json::parse(text);
    } catch (const Json::parse_error& e) {
        return Status::errorf(where, ": not valid JSON: ", e.what());
    } catch (const std::exception& e) {
        return Status::errorf(where, ": not valid JSON: ", e.what());
    }
    if (Status s = expect_object(j, ""); !s)
        return Status::errorf(where, ": ", s.message());

    Stock stock;
    const std::set<std::string> other_keys = { "name", "description", "layers", "inhibition",
                                               "rear_face", "printing_density" };
    Status s = read_numbers(j, kStockFields, other_keys, "", stock);
    if (s)
        s = read_string(j, "name", "", stock.name);
    if (s && j.contains("rear_face"))
        s = read_word(j, kRearFaceField, "", stock);
    if (s)
        s = read_string(j, "description", "", stock.description);
    if (s) {
        auto it = j.find("layers");
        if (it != j.end()) {
            if (!it->is_array()) {
                s = Status::errorf("layers must be an array of objects, not ", type_name(*it));
            } else {
                stock.layers.clear();
                for (size_t i = 0; i < it->size() && s; ++i) {
                    Layer layer;
                    s = parse_layer((*it)[i], "layers[" + std::to_string(i) + "]", layer);
                    stock.layers.push_back(layer);
                }
            }
        }
    }
    if (s) {
        auto it = j.find("inhibition");
        if (it != j.end()) {
            const auto bad = [&] {
                return Status::errorf("inhibition must be an array of arrays of numbers (one row "
                                      "per layer), not ", it->dump());
            };
            if (!it->is_array())
                s = bad();
            for (size_t k = 0; s && k < it->size(); ++k) {
                const Json& row = (*it)[k];
                if (!row.is_array()) {
                    s = bad();
                    break;
                }
                stock.inhibition.emplace_back();
                for (const Json& v : row) {
                    if (!v.is_number()) {
                        s = Status::errorf("inhibition[", k, "] must hold numbers, not ",
                                           type_name(v), " (", v.dump(), ")");
                        break;
                    }
                    stock.inhibition.back().push_back(v.get<double>());
                }
            }
        }
    }
    if (s) {
        auto it = j.find("printing_density");
        if (it != j.end())
            s = parse_printing_density(*it, stock);
    }
    if (s)
        s = stock.validate();
    if (!s)
        return Status::errorf(where, ": ", s.message());
    if (!stock.inhibits())
        stock.inhibition.clear();  // all zero: stored empty
    out = std::move(stock);
    return {};
}

std::string stock_to_json(const Stock& stock, int indent)
{
    Json j;
    j["name"]        = stock.name;
    j["description"] = stock.description;
    for (const auto& f : kStockFields)
        j[f.key] = stock.*(f.member);
    j["rear_face"]  = name_of(stock.rear_face);
    j["inhibition"] = Json::array();
    for (size_t k = 0; k < stock.layers.size(); ++k) {
        Json row = Json::array();
        for (size_t l = 0; l < stock.layers.size(); ++l)
            row.push_back(stock.inhibition.empty() ? 0.0 : stock.inhibition[k][l]);
        j["inhibition"].push_back(row);
    }
    j["layers"] = Json::array();
    for (const Layer& layer : stock.layers) {
        Json jl;
        jl["name"]        = layer.name;
        jl["sensitivity"] = layer.sensitivity;
        for (const auto& f : kLayerFields)
            jl[f.key] = layer.*(f.member);
        jl["halation_kernel"] = name_of(layer.halation_kernel);
        jl["image"]           = name_of(layer.image);
        jl["cloud_profile"]   = name_of(layer.cloud_profile);
        jl["populations"] = Json::array();
        for (const Population& pop : layer.populations) {
            Json jp;
            for (const auto& f : kPopulationFields)
                jp[f.key] = pop.*(f.member);
            jl["populations"].push_back(jp);
        }
        j["layers"].push_back(jl);
    }
    if (stock.status_m_to_apd)  // absent: APD = Status M (MODEL.md 11)
        j["printing_density"]["status_m_to_apd"] = { { "matrix", stock.status_m_to_apd->matrix },
                                                     { "offset", stock.status_m_to_apd->offset } };
    return j.dump(indent);
}

std::vector<std::string> preset_names()
{
    std::vector<std::string> names;
    for (const auto& p : embedded_presets())
        names.push_back(p.name);
    return names;
}

const char* default_preset_name() { return "vision3-500t"; }

std::string preset_json(const std::string& name)
{
    for (const auto& p : embedded_presets())
        if (name == p.name)
            return p.json;
    return {};
}

Status load_stock(const std::string& name_or_path, Stock& out)
{
    const std::string preset = preset_json(name_or_path);
    if (!preset.empty())
        return parse_stock_json(preset, "preset " + name_or_path, out);
    std::ifstream in(name_or_path, std::ios::binary);
    if (!in) {
        std::string names;
        for (const auto& n : preset_names())
            names += (names.empty() ? "" : ", ") + n;
        return Status::errorf("stock '", name_or_path,
                              "' is neither a built-in preset (", names,
                              ") nor a readable file");
    }
    std::ostringstream text;
    text << in.rdbuf();
    if (in.bad())
        return Status::errorf("stock file '", name_or_path, "': read error");
    return parse_stock_json(text.str(), name_or_path, out);
}

}  // namespace filmgrain
