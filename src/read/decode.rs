//! Binary payloads of VTU DataArrays: base64, compression, byte order, scalar types.
