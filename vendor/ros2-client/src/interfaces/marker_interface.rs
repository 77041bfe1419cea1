use serde::{Deserialize, Serialize};

use crate::Message;

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MarkerRequest {
  pub marker: String,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct MarkerResponse {
  pub marker: String,
}
