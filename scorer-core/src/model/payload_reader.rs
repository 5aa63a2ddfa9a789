//! Reads each model kind's payload struct by hand with [`WireReader`], field by field in the
//! order its serde derive writes them (see `crate::wire_reader` for why: one postcard
//! deserialiser per type costs the firmware images kilobytes of flash).
use postcard::Error;

use crate::gssm::{GssmModel, GssmScore};
use crate::mlp::{FloatLayer, FloatMlp, QuantLayer, QuantMlp};
use crate::msra::{MsraModel, MsraTerm};
use crate::surrogates::SurrogateKind;
use crate::wire_reader::WireReader;

/// [`GssmScore`]'s variants in wire order.
const GSSM_SCORES: [GssmScore; 3] = [GssmScore::Intensity, GssmScore::Cdf, GssmScore::Logit];

pub(super) fn quant_mlp<'a>(r: &mut WireReader<'a>) -> Result<QuantMlp<'a>, Error> {
    Ok(QuantMlp {
        inputs: r.bounded(WireReader::byte)?,
        input_mul: r.bounded(WireReader::f32)?,
        input_add: r.bounded(WireReader::f32)?,
        input_zero_point: r.i8()?,
        layers: r.bounded(quant_layer)?,
        output_scales: r.bounded(WireReader::f32)?,
    })
}

fn quant_layer<'a>(r: &mut WireReader<'a>) -> Result<QuantLayer<'a>, Error> {
    Ok(QuantLayer {
        out_dim: r.u16()?,
        relu: r.bool()?,
        weights: r.bytes()?,
        bias: r.bytes()?,
        multipliers: r.bytes()?,
        shifts: r.bytes()?,
        output_zero_point: r.i8()?,
    })
}

pub(super) fn float_mlp<'a>(r: &mut WireReader<'a>) -> Result<FloatMlp<'a>, Error> {
    Ok(FloatMlp {
        inputs: r.bounded(WireReader::byte)?,
        input_scale: r.bounded(WireReader::f32)?,
        input_offset: r.bounded(WireReader::f32)?,
        layers: r.bounded(float_layer)?,
    })
}

fn float_layer<'a>(r: &mut WireReader<'a>) -> Result<FloatLayer<'a>, Error> {
    Ok(FloatLayer {
        out_dim: r.u16()?,
        relu: r.bool()?,
        weights: r.bytes()?,
        bias: r.bytes()?,
    })
}

pub(super) fn msra<'a>(r: &mut WireReader<'a>) -> Result<MsraModel<'a>, Error> {
    Ok(MsraModel {
        terms: r.bounded(msra_term)?,
        gssm: if r.is_some()? { Some(gssm(r)?) } else { None },
    })
}

fn msra_term(r: &mut WireReader<'_>) -> Result<MsraTerm, Error> {
    Ok(MsraTerm {
        kind: r.variant(&SurrogateKind::ALL)?,
        weight: r.f32()?,
        a: r.f32()?,
        b: r.f32()?,
        lo: r.f32()?,
        hi: r.f32()?,
    })
}

pub(super) fn gssm<'a>(r: &mut WireReader<'a>) -> Result<GssmModel<'a>, Error> {
    Ok(GssmModel {
        net: float_mlp(r)?,
        score: r.variant(&GSSM_SCORES)?,
    })
}
