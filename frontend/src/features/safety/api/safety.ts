import { apiGet, apiPost } from '@/lib/api-client';
import type { SafetyStatePayload } from '@/types/events';

export const getSafety = () => apiGet<SafetyStatePayload>('/api/safety');

/** Clear stop: the operator says why it is safe to move again. Resumes nothing. */
export const clearStop = (reason: string) => apiPost<SafetyStatePayload>('/api/safety/clear', { reason });
